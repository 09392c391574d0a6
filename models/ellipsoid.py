"""The seed paper's test object: an ellipsoid, its 55 model points and its analytic surface.

The paper gives neither the ellipsoid's size nor its units, and states the noise as a
variance equal to 1/20 of the largest absolute coordinate: a rule that depends on the unit.
We read its lengths in millimetres, the unit of its robot cell, and take semi-axes of
100, 60 and 40 mm: a triaxial ellipsoid, whose symmetry group is the four rotations by 0 or
180 deg about its axes. Inside the code lengths are in metres, as everywhere.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Semi-axes (a, b, c) of the paper's ellipsoid [m].
RADII: tuple[float, float, float] = (0.10, 0.06, 0.04)
#: Parameter domain of r(u, v): u is the longitude, v the colatitude.
U_RANGE: tuple[float, float] = (0.0, 2.0 * np.pi)
V_RANGE: tuple[float, float] = (0.0, np.pi)


def surface_point(u: Array, v: Array, radii: tuple[float, float, float] = RADII) -> Array:
    """r(u, v) on the ellipsoid, shape (..., 3), for longitude u and colatitude v [rad]."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    a, b, c = radii
    return np.stack([a * np.cos(u) * np.sin(v), b * np.sin(u) * np.sin(v), c * np.cos(v)], -1)


def model_points(
    count: int = 55, seed: int = 1995, radii: tuple[float, float, float] = RADII
) -> Array:
    """The model set X: `count` random points on the ellipsoid (seeded), (N, 3).

    Random rather than a regular lattice: a lattice nearly maps onto itself under the
    ellipsoid's 180-degree rotations, which would make the true pose only one of four
    equally good fits once noise is added.
    """
    return sample_surface(count, seed, radii)


def symmetry_rotations() -> Array:
    """The rotations (4, 3, 3) that map a triaxial ellipsoid centred at the origin onto itself."""
    return np.array([np.diag(d) for d in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1])], float)


def sample_surface(count: int, seed: int = 0, radii: tuple[float, float, float] = RADII) -> Array:
    """`count` random points on the ellipsoid surface, (count, 3) (uniform in direction)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u = np.arctan2(d[:, 1], d[:, 0])
    v = np.arccos(np.clip(d[:, 2], -1.0, 1.0))
    return surface_point(u, v, radii)
