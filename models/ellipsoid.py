"""The seed paper's test object: an ellipsoid, its 55 model points and its analytic surface.

The paper does not give the ellipsoid's size; its noise is stated relative to the largest
coordinate of the data, so the experiments are scale-free. The semi-axes here are
(10, 6, 4) in the paper's abstract units, a triaxial ellipsoid (its symmetry group is the
four rotations by 0 or 180 deg about its axes).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Semi-axes (a, b, c) of the paper's ellipsoid, in the paper's abstract units.
RADII: tuple[float, float, float] = (10.0, 6.0, 4.0)
#: Parameter domain of r(u, v): u is the longitude, v the colatitude.
U_RANGE: tuple[float, float] = (0.0, 2.0 * np.pi)
V_RANGE: tuple[float, float] = (0.0, np.pi)


def surface_point(u: Array, v: Array, radii: tuple[float, float, float] = RADII) -> Array:
    """r(u, v) on the ellipsoid, shape (..., 3), for longitude u and colatitude v [rad]."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    a, b, c = radii
    return np.stack([a * np.cos(u) * np.sin(v), b * np.sin(u) * np.sin(v), c * np.cos(v)], -1)


def model_points(count: int = 55, radii: tuple[float, float, float] = RADII) -> Array:
    """The model set X: `count` points spread over the ellipsoid (Fibonacci lattice), (N, 3).

    Deterministic; not symmetric under the ellipsoid's 180-degree rotations, so the true pose
    of a noise-free copy is the unique exact match.
    """
    k = np.arange(count) + 0.5
    v = np.arccos(1.0 - 2.0 * k / count)
    u = np.mod(np.pi * (1.0 + 5.0**0.5) * k, 2.0 * np.pi)
    return surface_point(u, v, radii)


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
