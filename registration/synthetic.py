"""Synthetic shapes and scans with known ground truth, for tests, benchmarks and demos.

Nothing here is used by the matcher itself: it makes data whose true pose is known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration.rigid import Array, invert, random_transform, transform_points
from registration.shapes.mesh_shape import sample_surface


def icosphere(subdivisions: int) -> tuple[Array, Array]:
    """Unit icosphere: vertices (V, 3), faces (F, 3); F = 20 * 4**subdivisions."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=float,
    )  # fmt: skip
    f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
    )  # fmt: skip
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = v[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(3, -1) + len(v)
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        ab, bc, ca = m[0], m[1], m[2]
        f = np.concatenate(
            [np.stack(x, 1) for x in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))]
        )
        v = np.vstack([v, mid])
    return v, f


def asymmetric_blob(size: float = 0.2, subdivisions: int = 5, seed: int = 0) -> tuple[Array, Array]:
    """A smooth, star-shaped, asymmetric closed mesh about `size` long [m].

    An ellipsoid with eight random bumps: no rotation maps it onto itself (almost surely).
    Returns vertices (V, 3) and faces (F, 3).
    """
    v, f = icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    dirs = rng.normal(size=(8, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    s = np.ones(len(v))
    for d, a in zip(dirs, rng.uniform(0.15, 0.4, 8), strict=True):
        s += a * np.exp(-np.sum((v - d) ** 2, axis=1) / 0.3)
    v = v * s[:, None] * np.array([0.5, 0.35, 0.3])
    v *= size / np.ptp(v[:, 0])
    return v, f


@dataclass(frozen=True)
class SyntheticScan:
    """A scan with its ground truth.

    Attributes:
        points: data points (N, 3) in the data frame.
        T_model_data: the true pose (4, 4), data -> model.
        inlier: (N,) True for points on the surface, False for spurious ones.
    """

    points: Array
    T_model_data: Array
    inlier: Array


def partial_scan(
    vertices: Array,
    faces: Array,
    count: int,
    view: Array | tuple[float, float, float] = (0.0, 0.0, 1.0),
    min_cosine: float = 0.2,
    noise: float = 0.0,
    outlier_fraction: float = 0.0,
    seed: int = 0,
    translation_scale: float = 0.1,
) -> SyntheticScan:
    """Points seen from one side of a mesh, moved by a random rigid transform.

    Points whose normal makes an angle of less than arccos(min_cosine) with the view
    direction are kept (self-occlusion is ignored); Gaussian noise of sigma `noise` [m] is
    added; a fraction of the points is replaced by uniform outliers in the padded bounding box.
    min_cosine=-1 keeps the whole surface (global matching).
    """
    rng = np.random.default_rng(seed)
    view_dir = np.asarray(view, dtype=float)
    view_dir /= np.linalg.norm(view_dir)
    pts, normals = sample_surface(vertices, faces, 20 * count + 1000, seed=seed)
    visible = pts[normals @ view_dir >= min_cosine]
    pick = visible[rng.choice(len(visible), size=count, replace=len(visible) < count)]
    pick = pick + rng.normal(scale=noise, size=pick.shape) if noise > 0 else pick
    inlier = np.ones(count, dtype=bool)
    n_out = round(outlier_fraction * count)
    if n_out:
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        pad = 0.2 * (hi - lo)
        out = rng.choice(count, size=n_out, replace=False)
        pick[out] = rng.uniform(lo - pad, hi + pad, size=(n_out, 3))
        inlier[out] = False
    T_data_model = random_transform(rng, translation_scale)
    return SyntheticScan(transform_points(T_data_model, pick), invert(T_data_model), inlier)
