"""The search for candidate poses: initial states, all scored at once, the best refined
together, the distinct survivors returned.

1. Initial states (starts.py) for the mode:
   - "global" (the data cover the whole surface, eq. 9): near-uniform rotations, each
     with the data's robust centre placed on the model's centroid;
   - "local" (the data cover part of it, eq. 10): a data point placed on well-spread model
     anchors, its normal aligned with theirs (both signs) and spun about it; every rotation
     at every anchor for sparse data;
   - "auto": both sets in one pool, scored alike, so that a scan covering anything from a
     small patch to the whole surface is found without knowing which it is;
   - the caller's guess, if any, in every mode.
2. Every start scored at once on a small subsample of the data against the model's surface
   sample (a voxel lookup); hopeless starts are dropped.
3. Successive screening: the best few hundred run three robust ICP iterations together on
   a few dozen points (a start 20-30 mm from a small patch's pose scores no better than a
   wrong one before it moves, and clearly better after), then the best few dozen run more
   iterations on more points, vectorised.
4. The distinct survivors are the candidates that the matcher refines and judges.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from registration.horn import absolute_orientation_batch
from registration.kernels import Kernel, Tukey
from registration.quality import trimmed_rms
from registration.rigid import Array, make_T_batch, transform_points
from registration.shapes.base import Closest, Shape
from registration.starts import (
    global_starts,
    grid_local_starts,
    local_starts,
    robust_centre,
    super_fibonacci_rotations,
)

Progress = Callable[[str], None]


@dataclass(frozen=True)
class SearchSettings:
    """Size of the start set and of each stage of the coarse-to-fine search.

    Attributes:
        rotations: rotations of the global start set.
        anchors: model anchor points of the local start set, for a scan at least 0.7 of the
            model's size; smaller scans get up to four times as many.
        spins: rotations about the aligned normal at each anchor (local).
        data_anchors: data points placed on the model anchors (local), well spread over the
            scan's interior: a single one may fall where the model has no surface.
        normal_radius: neighbourhood radius for the local normals, as a fraction of the
            model extent.
        coarse_points: data points used to score every start.
        screen_keep: starts kept after scoring, for the screening ICP stage.
        screen_points: data points of the screening stage.
        screen_iterations: ICP iterations of the screening stage.
        keep_coarse: starts kept after screening (at least).
        mid_budget: point evaluations per iteration of the vectorised ICP stage; data sets
            smaller than mid_points keep more starts (mid_budget / points).
        mid_points: data points of the vectorised ICP stage.
        mid_iterations: iterations of the vectorised ICP stage.
        refine: distinct candidates refined and ranked.
        refine_points: data points (a seeded random subsample) on which the best pose is
            refined and its quality computed.
        dense_data, dense_model: below these numbers of data points or model surface samples,
            local normals are unreliable and the local start set is every rotation at every
            anchor instead of normal-aligned spins.
        whole_fit, whole_scale: if no candidate fits this fraction of the scan's surface
            points, or none has a robust residual scale below this fraction of a voxel of
            the coarse lookup (and twice the floor), the search runs again with twice the
            starts: a wrong minimum may have won.
        rank_points: data points on which the distinct candidates are refined together
            against the surface sample (more than mid_points: on a small patch a few
            hundred points can hold a start in a false minimum some 15 mm from the true
            one).
        rank_iterations: ICP iterations on that subsample for the distinct candidates, all
            together, against the surface sample (the scale annealed), before ...
        rank_exact_iterations: ... those against the exact model on mid_points; then the
            minima are ranked on mid_points.
        converge: ICP iterations (at most) in which the best minimum and its rivals are
            refined on rank_points before they are judged (a wrong pose may wander on).
        rivals: rivals refined (cheapest first) until one stays apart from the best.
        trim: fraction of the smallest residuals in a start's cost (robust to outliers and
            partial overlap); the minima are then compared on the fraction the best fits.
        distinct: two poses are distinct minima if they move the data points apart by more
            than this fraction of the model extent (RMS).
        judge_points: data points on which the two best minima are compared at the end.
        judge_margin: they are compared on the fraction of those points that the better
            one fits, less this margin (at least `trim`, at most 0.99).
        judge_unexplained: a minimum that leaves this fraction of those points more
            unexplained than the other, and at least twice as many, is no rival to it.
        reach: data points farther than this fraction of the model extent from the model
            are outliers of every refined pose (the closest-point search stops there).
    """

    rotations: int = 512
    anchors: int = 96
    spins: int = 16
    data_anchors: int = 3
    normal_radius: float = 0.06
    coarse_points: int = 40
    screen_keep: int = 384
    screen_points: int = 60
    screen_iterations: int = 3
    keep_coarse: int = 48
    mid_budget: int = 10000
    mid_points: int = 200
    mid_iterations: int = 8
    refine: int = 4
    refine_points: int = 2000
    rank_points: int = 500
    rank_iterations: int = 10
    rank_exact_iterations: int = 0
    converge: int = 20
    rivals: int = 3
    whole_fit: float = 0.95
    whole_scale: float = 0.25
    dense_data: int = 50
    dense_model: int = 2000
    trim: float = 0.6
    distinct: float = 0.02
    judge_points: int = 2000
    judge_margin: float = 0.01
    judge_unexplained: float = 0.02
    reach: float = 0.05

    def denser(self) -> SearchSettings:
        """The settings of a second, denser search: twice the rotations, model anchors,
        scan anchors (on a small patch, where a scan point lands decides whether a start
        comes near the pose) and survivors."""
        from dataclasses import replace

        return replace(
            self,
            rotations=2 * self.rotations,
            anchors=2 * self.anchors,
            data_anchors=2 * self.data_anchors,
            screen_keep=2 * self.screen_keep,
            keep_coarse=2 * self.keep_coarse,
            refine=2 * self.refine,
        )


def subsample(points: Array, count: int, rng: np.random.Generator) -> Array:
    """Indices (<= count,) of points drawn without replacement, in order (all if fewer)."""
    if len(points) <= count:
        return np.arange(len(points))
    return np.sort(rng.choice(len(points), size=count, replace=False))


#: Correspondences for K poses at once: moved points (K, n, 3) -> their model points
#: (K, n, 3), normals (K, n, 3) or None, and whether each has one (K, n).
Pairs = Callable[[Array], tuple[Array, Array | None, Array]]


def lookup_pairs(shape: Shape) -> Pairs:
    """The surface sample a voxel lookup finds (fast, to about a voxel)."""
    lookup, normals = shape.sample_lookup, shape.sample_normals

    def pairs(p: Array) -> tuple[Array, Array | None, Array]:
        _, idx = lookup.query(p)
        safe = np.maximum(idx, 0)
        return shape.samples[safe], None if normals is None else normals[safe], idx >= 0

    return pairs


def closest_pairs(closest: Callable[[Array], Closest], reach: float) -> Pairs:
    """The closest points of an operator (the exact one, say); none beyond `reach`."""

    def pairs(p: Array) -> tuple[Array, Array | None, Array]:
        c = closest(p.reshape(-1, 3))
        normals = None if c.normals is None else c.normals.reshape(p.shape)
        return c.points.reshape(p.shape), normals, (c.distances < reach).reshape(p.shape[:-1])

    return pairs


def batched_icp(
    points: Array,
    T: Array,
    iterations: int,
    trim: float,
    kernel: Kernel,
    pairs: Pairs,
    reach: float,
    anneal: float = 0.0,
) -> tuple[Array, Array]:
    """A few robust ICP iterations for K poses at once, vectorised.

    Point-to-plane where the correspondences have normals, else Horn's method. A point
    without a correspondence counts as a residual of `reach` and has no weight. With
    `anneal` > 0 and Tukey's kernel, the scale's floor starts at `anneal` [length units] and
    shrinks geometrically to the kernel's own over the first two thirds of the iterations:
    a pose slid a few millimetres along a flat face is pulled back by the points beyond its
    edge before the cut-off excludes them (at the final scale a slid pose is a minimum).

    Args:
        points: data subsample (n, 3). T: poses (K, 4, 4).

    Returns:
        Refined poses (K, 4, 4) and their trimmed costs (K,): the RMS of the smallest `trim`
        fraction of the point-to-plane residuals (distances where there are no normals).
    """

    def residuals(p: Array) -> tuple[Array, Array, Array | None, Array]:
        q, nrm, found = pairs(p)
        r = np.linalg.norm(p - q, axis=2) if nrm is None else np.sum(nrm * (p - q), axis=2)
        return np.where(found, r, reach), q, nrm, found

    schedule = None
    if anneal > 0 and isinstance(kernel, Tukey) and iterations > 1:
        end = max(kernel.min_scale, 1e-12 * anneal)
        steps = max(1, (2 * iterations) // 3)
        schedule = np.maximum(anneal * (end / anneal) ** (np.arange(iterations) / steps), end)
    for k in range(iterations):
        p = points @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
        r, q, nrm, found = residuals(p)
        if isinstance(kernel, Tukey):
            # The scale of the points that found the surface: placeholders at the reach,
            # if they are more than half, would make it zero.
            scale = kernel.scale(r, found)
            if schedule is not None:
                scale = np.maximum(scale, schedule[k])
            w = kernel.weights_at(r, scale) * found
        else:
            w = kernel.weights(r) * found
        if nrm is None:
            R, t = absolute_orientation_batch(p, q, w)
            step = make_T_batch(R, t)
        else:
            c0 = np.einsum("kn,knd->kd", w, p) / np.maximum(w.sum(1), 1e-300)[:, None]
            pc = p - c0[:, None]
            J = np.concatenate([nrm, np.cross(pc, nrm)], axis=2)  # (K, n, 6)
            Jw = J * w[..., None]
            A = Jw.transpose(0, 2, 1) @ J
            b = -(Jw.transpose(0, 2, 1) @ r[..., None])[..., 0]
            A += np.eye(6) * (1e-9 * np.trace(A, axis1=1, axis2=2)[:, None, None] + 1e-300)
            xi = np.linalg.solve(A, b[..., None])[..., 0]
            Rs = Rotation.from_rotvec(xi[:, 3:]).as_matrix()
            t = c0 - np.einsum("kij,kj->ki", Rs, c0) + xi[:, :3]
            step = make_T_batch(Rs, t)
        T = step @ T
    # The cost: point-to-plane residuals where there are normals (a lookup's sample may lie
    # a voxel away along the surface, which a point distance would count).
    p = points @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
    r, _, _, _ = residuals(p)
    return T, trimmed_rms(np.minimum(np.abs(r), reach), trim)


def displacement(T_a: Array, T_b: Array, points: Array) -> float:
    """RMS distance between points (N, 3) moved by two poses (4, 4)."""
    diff = transform_points(T_a, points) - transform_points(T_b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def distinct(
    T_list: list[Array], order: Array, points: Array, limit: float, count: int
) -> list[int]:
    """Indices, in the given order, of up to `count` mutually distinct poses."""
    chosen: list[int] = []
    for i in order:
        if all(displacement(T_list[i], T_list[j], points) > limit for j in chosen):
            chosen.append(int(i))
            if len(chosen) == count:
                break
    return chosen


def anchor_count(data: Array, extent: float, settings: SearchSettings) -> int:
    """Model anchors for local starts: more where the scan covers a smaller part of the model.

    A small patch has a small basin of convergence, so the anchors must lie closer together:
    their number grows with (0.7 model extent / scan extent)^2, up to four times the
    base count, in steps of 32 (the anchor frames are cached per count).
    """
    lo, hi = np.percentile(data, [2, 98], axis=0)
    ratio = max(float(np.linalg.norm(hi - lo)) / extent, 1e-9)
    count = settings.anchors * min(max((0.7 / ratio) ** 2, 1.0), 4.0)
    return int(np.ceil(count / 32) * 32)


def initial_states(
    data: Array, shape: Shape, mode: str, settings: SearchSettings
) -> tuple[Array, Array]:
    """Starts (R (K, 3, 3), t (K, 3)) of the mode: "global", "local" or "auto" (both)."""
    parts: list[tuple[Array, Array]] = []
    if mode in ("global", "auto"):
        centre = robust_centre(data, settings.normal_radius * shape.extent)
        parts.append(
            global_starts(centre, shape.centroid, super_fibonacci_rotations(settings.rotations))
        )
    if mode in ("local", "auto"):
        extent = shape.extent
        radius = settings.normal_radius * extent
        anchors, frames = shape.anchor_frames(anchor_count(data, extent, settings), radius)
        dense = len(data) >= settings.dense_data and len(shape.samples) >= settings.dense_model
        if dense:
            parts.append(
                local_starts(data, anchors, frames, settings.spins, radius, settings.data_anchors)
            )
        else:
            parts.append(
                grid_local_starts(data, anchors, super_fibonacci_rotations(settings.rotations))
            )
    R = np.concatenate([p[0] for p in parts])
    t = np.concatenate([p[1] for p in parts])
    return R, t


@dataclass(frozen=True, eq=False)
class Found:
    """What `search` found: distinct `candidates` (4, 4) from `starts` initial states, and
    for a picture of it, the initial states (K, 4, 4) with their scores (K,) and the
    survivors after the coarse ICP (M, 4, 4) with their costs (M,)."""

    candidates: list[Array]
    starts: int
    start_poses: Array
    start_costs: Array
    minima: Array
    minima_costs: Array


def search(
    data: Array,
    mid: Array,
    shape: Shape,
    mode: str,
    settings: SearchSettings,
    rng: np.random.Generator,
    kernel: Kernel,
    stage: dict[str, float],
    say: Progress,
) -> Found:
    """Initial states, scored at once, the best refined together: distinct candidates.

    Args:
        data: the data points the initial states are built from (N, 3).
        mid: the subsample of the vectorised ICP stage (n, 3).

    Returns the candidate poses (4, 4), the number of initial states tried and the trace.
    """
    extent = shape.extent
    t0 = time.perf_counter()
    R, t = initial_states(data, shape, mode, settings)
    n_starts = len(R)
    coarse = mid[subsample(mid, settings.coarse_points, rng)]
    lookup = shape.sample_lookup
    cost = np.empty(n_starts)
    for lo in range(0, n_starts, 8192):  # bounded memory for large start sets
        hi = min(lo + 8192, n_starts)
        p = coarse @ R[lo:hi].transpose(0, 2, 1) + t[lo:hi, None, :]
        d = lookup.distance(p)
        cost[lo:hi] = trimmed_rms(np.minimum(d, lookup.reach), settings.trim)
    screened = np.argsort(cost, kind="stable")[: settings.screen_keep]
    stage["score"] = stage.get("score", 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    few = mid[subsample(mid, settings.screen_points, rng)]
    pairs = lookup_pairs(shape)
    T_few, cost_few = batched_icp(
        few, make_T_batch(R[screened], t[screened]), settings.screen_iterations,
        settings.trim, kernel, pairs, lookup.reach,
    )  # fmt: skip
    # Small data sets afford more survivors for the same work.
    n_keep = max(settings.keep_coarse, settings.mid_budget // len(mid))
    keep = np.argsort(cost_few, kind="stable")[:n_keep]
    stage["screen"] = stage.get("screen", 0.0) + time.perf_counter() - t0
    say(f"scored {n_starts} initial states, screened {len(screened)}, kept {len(keep)}")

    t0 = time.perf_counter()
    T_mid, cost_mid = batched_icp(
        mid, T_few[keep], settings.mid_iterations, settings.trim, kernel, pairs, lookup.reach
    )
    T_list = list(T_mid)
    chosen = distinct(
        T_list, np.argsort(cost_mid, kind="stable"), mid, settings.distinct * extent,
        settings.refine,
    )  # fmt: skip
    stage["coarse_icp"] = stage.get("coarse_icp", 0.0) + time.perf_counter() - t0
    say(f"coarse ICP on {len(keep)} starts, refining {len(chosen)} distinct candidates")
    return Found([T_list[i] for i in chosen], n_starts, make_T_batch(R, t), cost, T_mid, cost_mid)
