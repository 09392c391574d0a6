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

from dataclasses import dataclass

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
    diff = points - points[chosen[0]]
    d2 = np.einsum("ij,ij->i", diff, diff)
    for k in range(1, count):
        chosen[k] = int(np.argmax(d2))
        diff = points - points[chosen[k]]
        np.minimum(d2, np.einsum("ij,ij->i", diff, diff), out=d2)
    return chosen


def local_frame(points: Array, centers: Array, radius: float, tree: cKDTree | None = None) -> Array:
    """Orthonormal frames (K, 3, 3) at centers (K, 3): columns e1, e2, n by PCA within radius.

    n is the direction of least spread (the surface normal, sign arbitrary) and e1 the
    direction of largest spread. A centre with fewer than 3 points within the radius takes
    its 8 nearest.
    """
    tree = tree or cKDTree(points)
    lists = tree.query_ball_point(centers, radius)
    few = [k for k, nb in enumerate(lists) if len(nb) < 3]
    if few:
        _, near = tree.query(centers[few], k=min(8, len(points)))
        for k, nb in zip(few, np.atleast_2d(near), strict=True):
            lists[k] = list(np.atleast_1d(nb))
    lengths = np.array([len(nb) for nb in lists])
    index = np.concatenate([np.asarray(nb, dtype=np.int64) for nb in lists])
    q = points[index] - np.repeat(centers, lengths, axis=0)
    outer = q[:, :, None] * q[:, None, :]
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    _, vecs = np.linalg.eigh(np.add.reduceat(outer, starts, axis=0))
    e1, n = vecs[:, :, 2], vecs[:, :, 0]
    return np.stack([e1, np.cross(n, e1), n], axis=2)


def robust_centre(data: Array, radius: float) -> Array:
    """Centroid (3,) of the data's surface points: points with few neighbours within `radius`
    (spurious returns, scattered in space) are left out.

    A whole-surface scan's centroid is the model's; 40 % of scattered outliers would move the
    plain mean by a large fraction of the object's size.
    """
    pool = data[:: max(1, len(data) // 500)]
    counts = cKDTree(pool).query_ball_point(pool, radius, return_length=True)
    dense = counts >= 0.25 * np.median(counts)
    return pool[dense].mean(axis=0)


@dataclass(frozen=True)
class SurfacePoints:
    """Which points (N,) lie on the scanned surface, as opposed to spurious returns
    scattered in space.

    Attributes:
        loose: the density test alone (kept for the search and the refinement, sharp edges
            included).
        strict: a stricter density test and the flatness test (the points a right pose of
            the right object must fit; sharp edges and spurious points near the surface
            left out).
    """

    loose: Array
    strict: Array


def surface_points(
    points: Array, data: Array, k: int = 8, spread: tuple[float, float] = (3.0, 2.0),
    flat: float = 0.25,
) -> SurfacePoints:  # fmt: skip
    """Which of the points (N, 3) lie on the scanned surface, judged against the whole data
    (M, 3), by each point's k nearest neighbours among (about 8,000 of) the data:
    - density: the k-th neighbour lies about sqrt(k / (pi rho_surface)) away on a surface
      and (k / (4/3 pi rho_space))^(1/3) away in scattered clutter, several times farther
      at any sensible density; a point passes if that distance is at most `spread` times
      the median's (loose, strict; the density varies with range and incidence by less
      than spread^2);
    - flatness (strict only): a point on a surface lies on the plane of its neighbours, to
      the noise and the curvature; a spurious point near the surface has surface
      neighbours but lies off their plane. A point passes if its distance to that plane is
      at most `flat` times the neighbours' spread (RMS distance from their centroid).
    Holds while fewer than half the points are spurious; with fewer than 4 k points, all
    are kept.
    """
    if len(data) < 4 * k:
        every = np.ones(len(points), dtype=bool)
        return SurfacePoints(every, every)
    pool = data[:: max(1, len(data) // 8000)]
    d, idx = cKDTree(pool).query(points, k=k + 1)
    itself = d[:, 0] == 0.0  # a point of the pool finds itself first
    reach = np.where(itself, d[:, k], d[:, k - 1])
    median = np.median(reach)
    others = np.where(itself[:, None], idx[:, 1:], idx[:, :-1])
    nb = pool[others]
    centre = nb.mean(axis=1)
    q = nb - centre[:, None]
    _, vecs = np.linalg.eigh(np.einsum("nki,nkj->nij", q, q))
    off = np.abs(np.einsum("nd,nd->n", points - centre, vecs[:, :, 0]))
    size = np.sqrt(np.mean(np.einsum("nkd,nkd->nk", q, q), axis=1))
    loose = reach <= spread[0] * median
    strict = (reach <= spread[1] * median) & (off <= flat * size)
    return SurfacePoints(loose, strict)


def global_starts(
    data_centroid: Array, model_centroid: Array, rotations: Array
) -> tuple[Array, Array]:
    """Starts (R (K, 3, 3), t (K, 3)) that map the data centroid onto the model centroid."""
    t = model_centroid - rotations @ data_centroid
    return rotations, t


def data_anchors(data: Array, radius: float, count: int, tree: cKDTree | None = None) -> Array:
    """Well-spread data points (<= count, 3) inside the scanned surface, whatever the data's
    orientation: the first nearest the centroid of the scan's interior, the others its
    farthest points.

    The interior is the points with at least the median number of neighbours within
    `radius`: spurious points (sparse) and the scan's border (half a neighbourhood, an
    unreliable normal) are left out.
    """
    tree = tree or cKDTree(data)
    pool = np.arange(0, len(data), max(1, len(data) // 600))
    counts = tree.query_ball_point(data[pool], radius, return_length=True)
    core = data[pool[counts >= np.median(counts)]]
    first = int(np.argmin(np.linalg.norm(core - core.mean(axis=0), axis=1)))
    chosen = [first]
    d = np.linalg.norm(core - core[first], axis=1)
    for _ in range(min(count, len(core)) - 1):
        chosen.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(core - core[chosen[-1]], axis=1))
    return core[chosen]


def grid_local_starts(data: Array, model_anchors: Array, rotations: Array) -> tuple[Array, Array]:
    """Starts (R, t) for partial data: every rotation times every anchor translation.

    The data point nearest the data centroid is placed on each model anchor. The seed
    paper's set of initial rotations and translations; K = rotations * anchors.
    """
    p_anchor = data[np.argmin(np.linalg.norm(data - data.mean(axis=0), axis=1))]
    R = np.repeat(rotations[None], len(model_anchors), axis=0).reshape(-1, 3, 3)
    t = np.repeat(model_anchors, len(rotations), axis=0) - R @ p_anchor
    return R, t


def local_starts(
    data: Array,
    model_anchors: Array,
    model_frames: Array,
    spins: int,
    radius: float,
    data_count: int = 1,
) -> tuple[Array, Array]:
    """Starts (R (K, 3, 3), t (K, 3)) for partial data, K = data anchors * anchors * 2 * spins.

    Args:
        data: data points (N, 3).
        model_anchors: well-spread points on the model surface (A, 3).
        model_frames: their local frames (A, 3, 3) from `local_frame`.
        spins: rotations about the aligned normal, evenly spaced over 360 deg.
        radius: neighbourhood radius of the data normal [length units]; use the one the
            model frames were made with, so that both normals are smoothed alike.
        data_count: data anchors (see `data_anchors`): each is placed on every model anchor.
    """
    data_tree = cKDTree(data)
    p_anchors = data_anchors(data, radius, data_count, data_tree)
    F_data = local_frame(data, p_anchors, radius, data_tree)
    flip = np.diag([1.0, -1.0, -1.0])  # the other normal sign, still right-handed
    theta = 2.0 * np.pi * np.arange(spins) / spins
    c, s = np.cos(theta), np.sin(theta)
    Rz = np.zeros((spins, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1.0
    Rs, ts = [], []
    for p_anchor, F in zip(p_anchors, F_data, strict=True):
        F_both = np.stack([F, F @ flip])  # (2, 3, 3)
        # R = F_model @ Rz @ F_data^T, for every anchor, sign and spin.
        R = np.einsum("aij,sjk,blk->absil", model_frames, Rz, F_both).reshape(-1, 3, 3)
        Rs.append(R)
        ts.append(np.repeat(model_anchors, 2 * spins, axis=0) - R @ p_anchor)
    return np.concatenate(Rs), np.concatenate(ts)
