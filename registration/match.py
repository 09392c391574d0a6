"""Global and local surface matching behind one call: `match(data, model, mode=...)`.

Search, coarse to fine:
1. initial states (starts.py): rotations with centroids aligned (global), or anchors with
   aligned normals and spins (local), or the caller's guess (refine);
2. every start scored at once on a small farthest-point subsample of the data against the
   model's surface sample (one KD-tree query for all starts); hopeless starts are dropped;
3. the best starts run a few robust point-to-plane ICP iterations together, vectorised;
4. the best distinct survivors are refined to convergence against the exact model (mesh,
   points, segments or parametric surface) with the seed paper's stopping rule;
5. the distinct minima are ranked; the best gives the pose, the second-best the ambiguity;
   the covariance of the pose gives the predicted target registration error.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from registration.errors import InputError
from registration.horn import absolute_orientation_batch
from registration.icp import IcpResult, Variant, icp
from registration.kernels import Kernel, Tukey
from registration.quality import (
    Acceptance,
    ScanPasses,
    Verdict,
    decide,
    pose_covariance,
    predicted_tre,
    residual_correlation,
    trimmed_rms,
)
from registration.rigid import Array, make_T_batch, transform_points
from registration.shapes.base import Closest, Shape, check_points
from registration.shapes.mesh import MeshModel
from registration.shapes.points import PointModel
from registration.starts import (
    global_starts,
    grid_local_starts,
    local_starts,
    super_fibonacci_rotations,
)

Mode = Literal["global", "local", "refine"]
MODES: tuple[str, ...] = ("global", "local", "refine")
Progress = Callable[[str], None]


@dataclass(frozen=True)
class SearchSettings:
    """Size of the start set and of each stage of the coarse-to-fine search.

    Attributes:
        rotations: rotations of the global start set.
        anchors: model anchor points of the local start set, for a scan at least 0.7 of the
            model's size; smaller scans get up to four times as many.
        spins: rotations about the aligned normal at each anchor (local).
        normal_radius: neighbourhood radius for the local normals, as a fraction of the
            model extent.
        coarse_points: data points used to score every start.
        keep_coarse: starts kept after scoring (at least).
        mid_budget: point evaluations per iteration of the vectorised ICP stage; data sets
            smaller than mid_points keep more starts (mid_budget / points).
        mid_points: data points of the vectorised ICP stage.
        mid_iterations: iterations of the vectorised ICP stage.
        refine: distinct candidates refined to convergence on all data.
        dense_data, dense_model: below these numbers of data points or model surface samples,
            local normals are unreliable and the local start set is every rotation at every
            anchor instead of normal-aligned spins.
        whole_fit: if no candidate fits this fraction of the scan, the search runs again
            with twice the starts (the scan holds spurious points, or a wrong minimum won).
        rank_iterations: ICP iterations on the subsample for each distinct candidate, before
            the minima are ranked.
        trim: fraction of the smallest residuals in a start's cost (robust to outliers and
            partial overlap); the minima are then compared on the fraction the best fits.
        distinct: two poses are distinct minima if they move the data points apart by more
            than this fraction of the model extent (RMS).
        judge_points: data points on which the two best minima are compared at the end.
        judge_margin: they are compared on the fraction of those points that the better
            one fits, less this margin (at least `trim`, at most 0.99).
        judge_unexplained: a minimum that leaves this fraction of those points more
            unexplained than the other, and at least twice as many, is no rival to it.
    """

    rotations: int = 512
    anchors: int = 96
    spins: int = 16
    normal_radius: float = 0.06
    coarse_points: int = 40
    keep_coarse: int = 48
    mid_budget: int = 10000
    mid_points: int = 200
    mid_iterations: int = 8
    refine: int = 4
    rank_iterations: int = 20
    whole_fit: float = 0.97
    dense_data: int = 50
    dense_model: int = 2000
    trim: float = 0.6
    distinct: float = 0.02
    judge_points: int = 2000
    judge_margin: float = 0.01
    judge_unexplained: float = 0.02


@dataclass(frozen=True)
class Minimum:
    """A local minimum reached by a refined start.

    Attributes:
        T_model_data: (4, 4) pose.
        cost: RMS of the smallest residuals of the data subsample: as large a fraction as
            the best pose fits (between `trim` and 0.95) [length units].
    """

    T_model_data: Array
    cost: float


@dataclass(frozen=True)
class MatchResult:
    """Result of `match`.

    Attributes:
        T_model_data: (4, 4) maps data coordinates into model coordinates.
        rms: weighted RMS of the inlier residuals [length units].
        inlier_fraction: fraction of data points that fit the model (Tukey weight > 0).
        sigma: robust standard deviation of a residual [length units].
        iterations: ICP iterations of the best refinement.
        converged: the best refinement met the stopping rule before the cap.
        history: RMS per iteration of the best refinement (iterations,).
        trajectory: pose per iteration of the best refinement (iterations, 4, 4).
        mode: "global", "local" or "refine".
        starts: initial states evaluated.
        best: the best minimum; second: the best minimum distinct from it, or None.
        ambiguity: best cost / second cost in [0, 1]; 0 if no other minimum was found or
            the other leaves clearly more of the scan unexplained, near 1 if two distinct
            poses fit equally well.
        covariance: (6, 6) covariance of (dt, dtheta) applied in the model frame.
        worst_predicted_tre: largest predicted TRE over the model surface [length units].
        verdict: "accepted", "ambiguous" or "rejected"; reason: why, in words.
        seconds: wall time of the search.
    """

    T_model_data: Array
    rms: float
    inlier_fraction: float
    sigma: float
    iterations: int
    converged: bool
    history: Array
    trajectory: Array
    mode: str
    starts: int
    best: Minimum
    second: Minimum | None
    ambiguity: float
    covariance: Array
    worst_predicted_tre: float
    verdict: Verdict
    reason: str
    seconds: float
    stage_seconds: dict[str, float] = field(default_factory=dict)

    @property
    def rotation(self) -> Array:
        """R (3, 3) of T_model_data."""
        return self.T_model_data[:3, :3]

    @property
    def translation(self) -> Array:
        """t (3,) of T_model_data."""
        return self.T_model_data[:3, 3]

    def predicted_tre(self, targets_model: Array) -> Array:
        """Predicted target registration error (K,) at targets (K, 3) in the model frame."""
        return predicted_tre(self.covariance, targets_model)


def as_shape(model: Shape | Array | object) -> Shape:
    """A Shape from a Shape, an (N, 3) point array, or an object with vertices and faces."""
    if isinstance(model, Shape):
        return model
    if hasattr(model, "vertices") and hasattr(model, "faces"):
        return MeshModel(model.vertices, model.faces)  # type: ignore[attr-defined]
    if isinstance(model, np.ndarray | list | tuple):
        return PointModel(np.asarray(model, dtype=float))
    raise InputError(
        f"model must be a Shape (PointModel, SegmentModel, MeshModel, ParametricModel), an "
        f"(N, 3) array or a mesh with vertices and faces; got {type(model).__name__}"
    )


def check_data(data: Array) -> Array:
    """Validate data points: (N, 3), finite, N >= 3, not all on one line."""
    data = check_points(data, "data points", minimum=3)
    s = np.linalg.svd(data - data.mean(axis=0), compute_uv=False)
    if s[0] == 0 or s[1] <= 1e-9 * s[0]:
        raise InputError(
            f"the {len(data)} data points are all on one line (or one point): a rigid pose "
            f"needs points spanning at least a plane"
        )
    return data


def _anchor_count(data: Array, extent: float, settings: SearchSettings) -> int:
    """Model anchors for local starts: more where the scan covers a smaller part of the model.

    A small patch has a small basin of convergence, so the anchors must lie closer together:
    their number grows with (0.7 model extent / scan extent)^2, up to four times the
    base count, in steps of 32 (the anchor frames are cached per count).
    """
    lo, hi = np.percentile(data, [2, 98], axis=0)
    ratio = max(float(np.linalg.norm(hi - lo)) / extent, 1e-9)
    count = settings.anchors * min(max((0.7 / ratio) ** 2, 1.0), 4.0)
    return int(np.ceil(count / 32) * 32)


def _subsample(points: Array, count: int, rng: np.random.Generator) -> Array:
    """`count` points drawn without replacement (all of them if there are fewer)."""
    if len(points) <= count:
        return points
    return points[np.sort(rng.choice(len(points), size=count, replace=False))]


def _batched_icp(
    shape: Shape, points: Array, T: Array, iterations: int, trim: float
) -> tuple[Array, Array]:
    """A few robust ICP iterations for K poses at once against the model's surface sample.

    Closest samples come from the voxel lookup; pairs without a sample within its reach get
    no weight.

    Args:
        points: data subsample (n, 3). T: poses (K, 4, 4).

    Returns:
        Refined poses (K, 4, 4) and their trimmed costs (K,).
    """
    lookup = shape.sample_lookup
    normals = shape.sample_normals
    kernel = Tukey(min_scale=1e-4 * shape.extent)
    for _ in range(iterations):
        p = points @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
        d, idx = lookup.query(p)
        found = idx >= 0
        q = shape.samples[np.maximum(idx, 0)]
        if normals is None:
            w = kernel.weights(np.where(found, d, lookup.reach)) * found
            R, t = absolute_orientation_batch(p, q, w)
            step = make_T_batch(R, t)
        else:
            nrm = normals[np.maximum(idx, 0)]
            r = np.where(found, np.sum(nrm * (p - q), axis=2), lookup.reach)
            w = kernel.weights(r) * found
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
    p = points @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
    d, _ = lookup.query(p)
    return T, trimmed_rms(np.minimum(d, lookup.reach), trim)


def _displacement(T_a: Array, T_b: Array, points: Array) -> float:
    """RMS distance between points moved by two poses."""
    return float(
        np.sqrt(
            np.mean(np.sum((transform_points(T_a, points) - transform_points(T_b, points)) ** 2, 1))
        )
    )


def _distinct(
    T_list: list[Array], order: Array, points: Array, limit: float, count: int
) -> list[int]:
    """Indices, in the given order, of up to `count` mutually distinct poses."""
    chosen: list[int] = []
    for i in order:
        if all(_displacement(T_list[i], T_list[j], points) > limit for j in chosen):
            chosen.append(int(i))
            if len(chosen) == count:
                break
    return chosen


def _search(
    data: Array,
    mid: Array,
    shape: Shape,
    mode: str,
    settings: SearchSettings,
    rng: np.random.Generator,
    stage: dict[str, float],
    say: Progress,
) -> tuple[list[Array], int]:
    """Initial states, scored at once, the best refined together: distinct candidates.

    Returns the candidate poses (4, 4) and the number of initial states tried.
    """
    extent = shape.extent
    t0 = time.perf_counter()
    if mode == "global":
        R, t = global_starts(
            data.mean(axis=0), shape.centroid, super_fibonacci_rotations(settings.rotations)
        )
    else:
        radius = settings.normal_radius * extent
        anchors, frames = shape.anchor_frames(_anchor_count(data, extent, settings), radius)
        dense = len(data) >= settings.dense_data and len(shape.samples) >= settings.dense_model
        if dense:
            R, t = local_starts(data, anchors, frames, settings.spins, radius)
        else:
            R, t = grid_local_starts(data, anchors, super_fibonacci_rotations(settings.rotations))
    n_starts = len(R)
    coarse = _subsample(mid, settings.coarse_points, rng)
    p = coarse @ R.transpose(0, 2, 1) + t[:, None, :]
    lookup = shape.sample_lookup
    d, _ = lookup.query(p)
    cost = trimmed_rms(np.minimum(d, lookup.reach), settings.trim)
    # Small data sets afford more survivors for the same work.
    n_keep = max(settings.keep_coarse, settings.mid_budget // len(mid))
    keep = np.argsort(cost)[:n_keep]
    stage["score"] = stage.get("score", 0.0) + time.perf_counter() - t0
    say(f"scored {n_starts} initial states, kept {len(keep)}")

    t0 = time.perf_counter()
    T_mid, cost_mid = _batched_icp(
        shape, mid, make_T_batch(R[keep], t[keep]), settings.mid_iterations, settings.trim
    )
    T_list = list(T_mid)
    chosen = _distinct(
        T_list, np.argsort(cost_mid), mid, settings.distinct * extent, settings.refine
    )
    stage["coarse_icp"] = stage.get("coarse_icp", 0.0) + time.perf_counter() - t0
    say(f"coarse ICP on {len(keep)} starts, refining {len(chosen)} distinct candidates")
    return [T_list[i] for i in chosen], n_starts


def _judge(
    data: Array, shape: Shape, T_best: Array, second: Minimum, settings: SearchSettings
) -> tuple[Array, float, Minimum, float]:
    """The two best minima compared on a larger subsample of the data.

    On a few hundred points, a pose that leaves a few per cent of the scan unexplained (a
    part slid along its extrusion, the legs of an L swapped) scores like the true one once
    the ranking trims its worst points. On `judge_points`, the points each pose explains are
    counted with one yardstick (Tukey's cut-off at the robust scale of the better pose). A
    pose that explains more than `judge_unexplained` more of the scan, and leaves at most
    half as much of it unexplained, wins, and the other is no rival (ambiguity 0); otherwise
    the two are compared on the fraction the better one fits, less `judge_margin`, and the
    ambiguity is the ratio of their costs. The poses are not refined again: two starts in
    one long valley would join, and a rival be lost.

    Returns the better pose, its cost, the other minimum and the ambiguity.
    """
    points = _subsample(data, settings.judge_points, np.random.default_rng(1))
    poses = (T_best, second.T_model_data)
    moved = [transform_points(T, points) for T in poses]
    residuals = [np.abs(_surface_residuals(shape.closest(p), p)) for p in moved]
    costs = [float(trimmed_rms(r, settings.trim)) for r in residuals]
    tukey = Tukey(min_scale=1e-6 * shape.extent)
    cut = tukey.c * float(tukey.scale(residuals[int(np.argmin(costs))]))
    explained = [float(np.mean(r <= cut)) for r in residuals]
    more, less = sorted(explained, reverse=True)
    clear = more - less > settings.judge_unexplained and 1.0 - more <= (1.0 - less) / 2
    first = int(np.argmax(explained)) if clear else int(np.argmin(costs))
    other = 1 - first
    trim = float(np.clip(explained[first] - settings.judge_margin, settings.trim, 0.99))
    costs = [float(trimmed_rms(r, trim)) for r in residuals]
    rival = Minimum(poses[other], costs[other])
    ambiguity = 0.0 if clear else min(1.0, costs[first] / max(costs[other], 1e-300))
    return poses[first], costs[first], rival, ambiguity


def _surface_residuals(closest: Closest, p: Array) -> Array:
    """Point-to-plane residuals (N,) of points (N, 3) in the model frame from their closest
    points on the model (distances if the shape has no normals)."""
    if closest.normals is None:
        return closest.distances
    return np.einsum("nd,nd->n", closest.normals, p - closest.points)


def match(
    data: Array,
    model: Shape | Array | object,
    mode: Mode = "local",
    T_init: Array | None = None,
    variant: Variant = "point_to_plane",
    kernel: Kernel | None = None,
    acceptance: Acceptance | None = None,
    settings: SearchSettings | None = None,
    max_iterations: int = 60,
    progress: Progress | None = None,
    passes: ScanPasses | None = None,
) -> MatchResult:
    """Register data points to a model surface and judge the result.

    Args:
        data: measured points (N, 3) in the data (sensor or robot) frame.
        model: the virtual model: a Shape, an (M, 3) point array, or a mesh object.
        mode: "global" (data cover the whole surface, eq. 9), "local" (data cover part of
            it, eq. 10; also works on whole-surface data), or "refine" (ICP from T_init only).
        T_init: initial guess (4, 4), required for "refine", ignored otherwise.
        variant: "point_to_plane" (default when the model has normals) or "point_to_point".
        kernel: robust kernel of the refinement; Tukey(c=8) with a scale floor by default.
        acceptance: thresholds of the verdict.
        settings: sizes of the coarse-to-fine search.
        max_iterations: ICP iteration cap of each refinement.
        progress: optional callable receiving one line per stage.
        passes: which scan pass each data point came from and the standard deviation of a
            pass's rigid offset (the arm's accuracy); widens the covariance accordingly.

    Returns:
        A MatchResult; poor or ambiguous matches are reported in `verdict`, not raised.
    """
    t_start = time.perf_counter()
    if mode not in MODES:
        raise InputError(f"unknown matching mode {mode!r}; valid: {', '.join(MODES)}")
    data = check_data(data)
    if passes is not None and np.shape(passes.labels) != (len(data),):
        raise InputError(
            f"passes.labels must give one pass per data point ({len(data)}); got shape "
            f"{np.shape(passes.labels)}"
        )
    shape = as_shape(model)
    settings = settings or SearchSettings()
    acceptance = acceptance or Acceptance()
    extent = shape.extent
    kernel = kernel or Tukey(min_scale=1e-6 * extent)
    say = progress or (lambda _msg: None)
    stage: dict[str, float] = {}

    # Random (seeded) subsamples keep the data's outlier fraction; a farthest-point sample
    # would pick the spurious points first.
    rng = np.random.default_rng(0)
    mid = _subsample(data, settings.mid_points, rng)
    if mode == "refine":
        if T_init is None:
            raise InputError("mode 'refine' needs T_init, the (4, 4) initial pose")
        T_init = np.asarray(T_init, dtype=float)
        if T_init.shape != (4, 4) or not np.isfinite(T_init).all():
            raise InputError(f"T_init must be a finite (4, 4) matrix; got shape {T_init.shape}")
        candidates = [T_init]
        n_starts = 1
    else:
        candidates, n_starts = _search(data, mid, shape, mode, settings, rng, stage, say)

    # Refine every distinct candidate on the subsample against the exact model, rank the
    # minima there (same points for all), then refine the best one on all the data.
    t0 = time.perf_counter()

    def rank(poses: list[Array]) -> list[IcpResult]:
        cap = min(settings.rank_iterations, max_iterations)
        return [
            icp(mid, shape, T0, variant=variant, kernel=kernel, max_iterations=cap) for T0 in poses
        ]

    def fitted(run: IcpResult) -> float:
        return float(np.mean(Tukey(min_scale=1e-6 * extent).weights(run.residuals) > 0))

    runs = rank(candidates)
    best_fit = max(fitted(run) for run in runs)
    if mode != "refine" and best_fit < settings.whole_fit:
        # No candidate fits the whole scan: either the scan holds spurious points, or the
        # search stopped in a wrong minimum that fits most of it. Search again, denser.
        denser = replace(
            settings,
            rotations=2 * settings.rotations,
            anchors=2 * settings.anchors,
            spins=settings.spins * 3 // 2,
            keep_coarse=2 * settings.keep_coarse,
            refine=2 * settings.refine,
        )
        say(f"the best candidate fits {best_fit:.0%} of the scan: searching again, denser")
        more, n_more = _search(data, mid, shape, mode, denser, rng, stage, say)
        runs += rank(more)
        n_starts += n_more
    costs = np.array([float(trimmed_rms(run.residuals, settings.trim)) for run in runs])
    best_i = int(np.argmin(costs))
    # The minima are compared on as many points as the best pose fits: a wrong pose that
    # slides along a smooth region may fit a large share of the scan, but not all of it.
    trim = float(np.clip(fitted(runs[best_i]) - 0.05, settings.trim, 0.95))
    costs = np.array([float(trimmed_rms(run.residuals, trim)) for run in runs])
    best_i = int(np.argmin(costs))
    second = None
    for i in np.argsort(costs):
        T_i = runs[int(i)].T_model_data
        if _displacement(T_i, runs[best_i].T_model_data, mid) > settings.distinct * extent:
            second = Minimum(T_i, float(costs[int(i)]))
            break
    T_best, best_cost, ambiguity = runs[best_i].T_model_data, float(costs[best_i]), 0.0
    if second is not None:
        T_best, best_cost, second, ambiguity = _judge(data, shape, T_best, second, settings)
    trajectory: list[Array] = []
    best_run = icp(
        data,
        shape,
        T_best,
        variant=variant,
        kernel=kernel,
        max_iterations=max_iterations,
        callback=lambda _k, T, _mse: trajectory.append(T.copy()),
    )
    best = Minimum(best_run.T_model_data, best_cost)
    stage["refine"] = time.perf_counter() - t0
    say(f"refined {len(runs)} candidates; best of {len(runs)} minima refined on all data")

    # Quality of the best pose, from its own residuals.
    p = transform_points(best.T_model_data, data)
    closest = shape.closest(p)
    residuals = _surface_residuals(closest, p)
    weights = Tukey(c=8.0, min_scale=1e-6 * extent).weights(residuals)
    inliers = weights > 0
    inlier_fraction = float(inliers.mean())
    rms = float(np.sqrt(np.mean(residuals[inliers] ** 2))) if inliers.any() else float("inf")
    dof = max(int(inliers.sum()) - 6, 1)
    sigma = float(np.sqrt(np.sum(weights * residuals**2) / max(weights.sum(), 1e-300)))
    sigma *= np.sqrt(inliers.sum() / dof) if inliers.any() else 1.0
    correlation = residual_correlation(p[inliers], residuals[inliers])
    covariance = pose_covariance(
        p, closest.normals, weights, max(sigma, 1e-12 * extent), correlation, passes
    )
    worst_tre = float(
        np.max(predicted_tre(covariance, shape.samples[:: max(1, len(shape.samples) // 2000)]))
    )
    verdict, reason = decide(rms, inlier_fraction, ambiguity, worst_tre, extent, acceptance)
    seconds = time.perf_counter() - t_start
    say(f"{verdict}: {reason}")
    return MatchResult(
        T_model_data=best.T_model_data,
        rms=rms,
        inlier_fraction=inlier_fraction,
        sigma=sigma,
        iterations=best_run.iterations,
        converged=best_run.converged,
        history=np.sqrt(best_run.mse_history),
        trajectory=np.asarray(trajectory),
        mode=mode,
        starts=n_starts,
        best=best,
        second=second,
        ambiguity=float(ambiguity),
        covariance=covariance,
        worst_predicted_tre=worst_tre,
        verdict=verdict,
        reason=reason,
        seconds=seconds,
        stage_seconds=stage,
    )
