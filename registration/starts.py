"""Initial states: the set of starting poses that keeps ICP out of local minima.

Global matching (the data cover the whole surface) starts from a near-uniform set of
rotations with the centroids aligned. Local matching (the data cover only part of the
surface) adds initial translations: a data point near the middle of the scan is placed on
each of a set of well-spread model anchor points, the scan's local normal aligned with the
anchor's normal (both signs), and the scan spun about that normal. Sparse data or models, whose
normals cannot be trusted, use every rotation of the global set at every anchor instead.
Both sets are built as arrays so that all starts are scored at once.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from registration.horn import quaternion_to_matrix
from registration.rigid import Array


def super_fibonacci_rotations(n: int) -> Array:
    """n near-uniform rotations (n, 3, 3): the super-Fibonacci spiral of Alexa (CVPR 2022)."""
    phi = np.sqrt(2.0)
    psi = 1.533751168755204288118041
    s = np.arange(n) + 0.5
    r = np.sqrt(s / n)
    R_ = np.sqrt(1.0 - s / n)
    alpha = 2.0 * np.pi * s / phi
    beta = 2.0 * np.pi * s / psi
    x, y, z, w = r * np.sin(alpha), r * np.cos(alpha), R_ * np.sin(beta), R_ * np.cos(beta)
    q = np.stack([w, x, y, z], axis=1)
    return quaternion_to_matrix(q)


def farthest_point_sample(points: Array, count: int, seed: int = 0) -> Array:
    """Indices (count,) of a farthest-point sample of points (N, 3): well spread, deterministic."""
    n = len(points)
    if count >= n:
        return np.arange(n)
    rng = np.random.default_rng(seed)
    chosen = np.empty(count, dtype=np.int64)
    chosen[0] = rng.integers(n)
    d = np.linalg.norm(points - points[chosen[0]], axis=1)
    for k in range(1, count):
        chosen[k] = int(np.argmax(d))
        d = np.minimum(d, np.linalg.norm(points - points[chosen[k]], axis=1))
    return chosen


def local_frame(points: Array, centers: Array, radius: float, tree: cKDTree | None = None) -> Array:
    """Orthonormal frames (K, 3, 3) at centers (K, 3): columns e1, e2, n by PCA within radius.

    n is the direction of least spread (the surface normal, sign arbitrary) and e1 the
    direction of largest spread.
    """
    tree = tree or cKDTree(points)
    frames = np.empty((len(centers), 3, 3))
    for k, nb in enumerate(tree.query_ball_point(centers, radius)):
        if len(nb) < 3:
            _, nb = tree.query(centers[k], k=min(8, len(points)))
        q = points[np.atleast_1d(nb)] - centers[k]
        _, vecs = np.linalg.eigh(q.T @ q)
        e1, n = vecs[:, 2], vecs[:, 0]
        frames[k] = np.stack([e1, np.cross(n, e1), n], axis=1)
    return frames


def global_starts(
    data_centroid: Array, model_centroid: Array, rotations: Array
) -> tuple[Array, Array]:
    """Starts (R (K, 3, 3), t (K, 3)) that map the data centroid onto the model centroid."""
    t = model_centroid - rotations @ data_centroid
    return rotations, t


def data_anchor(data: Array, radius: float, tree: cKDTree | None = None) -> Array:
    """A data point near the middle of the scan that lies on the surface, (3,).

    Among the tenth of the points nearest the median, the one with the most neighbours
    within `radius`: surface points are dense, spurious points (outliers) are sparse.
    """
    tree = tree or cKDTree(data)
    center = np.median(data, axis=0)
    k = max(1, min(len(data), len(data) // 10))
    _, near = tree.query(center, k=k)
    near = np.atleast_1d(near)
    counts = tree.query_ball_point(data[near], radius, return_length=True)
    return data[near[int(np.argmax(counts))]]


def grid_local_starts(data: Array, model_anchors: Array, rotations: Array) -> tuple[Array, Array]:
    """Starts (R, t) for partial data: every rotation times every anchor translation.

    The data point nearest the data centroid is placed on each model anchor. The seed
    paper's set of initial rotations and translations; K = rotations * anchors.
    """
    p_anchor = data[np.argmin(np.linalg.norm(data - np.median(data, axis=0), axis=1))]
    R = np.repeat(rotations[None], len(model_anchors), axis=0).reshape(-1, 3, 3)
    t = np.repeat(model_anchors, len(rotations), axis=0) - R @ p_anchor
    return R, t


def local_starts(
    data: Array,
    model_anchors: Array,
    model_frames: Array,
    spins: int,
    radius: float,
) -> tuple[Array, Array]:
    """Starts (R (K, 3, 3), t (K, 3)) for partial data, K = anchors * 2 * spins.

    Args:
        data: data points (N, 3).
        model_anchors: well-spread points on the model surface (A, 3).
        model_frames: their local frames (A, 3, 3) from `local_frame`.
        spins: rotations about the aligned normal, evenly spaced over 360 deg.
        radius: neighbourhood radius of the data normal [length units]; use the one the
            model frames were made with, so that both normals are smoothed alike.
    """
    data_tree = cKDTree(data)
    p_anchor = data_anchor(data, radius, data_tree)
    F_data = local_frame(data, p_anchor[None], radius, data_tree)[0]
    flip = np.diag([1.0, -1.0, -1.0])  # the other normal sign, still right-handed
    theta = 2.0 * np.pi * np.arange(spins) / spins
    c, s = np.cos(theta), np.sin(theta)
    Rz = np.zeros((spins, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1.0
    F_data_both = np.stack([F_data, F_data @ flip])  # (2, 3, 3)
    # R = F_model @ Rz @ F_data^T, for every anchor, sign and spin.
    R = np.einsum("aij,sjk,blk->absil", model_frames, Rz, F_data_both).reshape(-1, 3, 3)
    t = np.repeat(model_anchors, 2 * spins, axis=0) - R @ p_anchor
    return R, t
