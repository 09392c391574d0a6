"""Global and local surface matching behind one call: `match(data, model, ...)`.

The steps, coarse to fine:
1. the search (search.py): initial states for the mode, all scored at once, the best
   refined together, the distinct survivors kept (plus the caller's guess, if any);
2. each candidate refined by ICP on a subsample of the data, and the minima ranked and the
   two best judged against each other (judge.py); a minimum that differs from the best by a
   symmetry of the model (symmetry.py) is the same pose, not a rival;
3. the best refined to convergence on the points used (fast closest points first, the
   exact operator last), and its quality computed: the residuals, the covariance and the
   predicted TRE (quality.py), and the verdict for the model or for each target
   (verdict.py).

Every random choice is drawn from one seed: the same data, model and seed give the same
result, bit for bit.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, TypeGuard

import numpy as np

from registration.errors import InputError
from registration.icp import IcpResult, Variant, icp
from registration.judge import (
    Judge,
    Ranked,
    Ranking,
    fits,
    fitted_fraction,
    floored_ratio,
    moved_by,
    rank_minima,
    residual_scale,
    surface_residuals,
    symmetric_twin,
)
from registration.kernels import Kernel, Tukey
from registration.quality import ScanPasses, pose_covariance, predicted_tre, residual_correlation
from registration.result import MatchResult, Minimum, SearchTrace
from registration.rigid import Array, invert, transform_points
from registration.search import (
    Found,
    SearchSettings,
    batched_icp,
    closest_pairs,
    search,
    subsample,
)
from registration.shapes.base import Closest, Shape, check_points
from registration.shapes.mesh import MeshModel
from registration.shapes.points import PointModel
from registration.starts import surface_points
from registration.symmetry import Symmetry, find_symmetries
from registration.verdict import (
    Acceptance,
    Rival,
    TargetPrediction,
    Verdict,
    assess_targets,
    fit_rejection,
    model_verdict,
)

Mode = Literal["auto", "global", "local", "refine"]
MODES: tuple[str, ...] = ("auto", "global", "local", "refine")


def is_mode(name: str) -> TypeGuard[Mode]:
    """Whether `name` is one of the `MODES`."""
    return name in MODES


Progress = Callable[[str], None]

#: A scan more than this many times larger or smaller than the model is in other units.
_UNITS_RATIO = 30.0


def as_shape(model: Shape | Array | object) -> Shape:
    """A Shape from a Shape, an (N, 3) point array, or an object with vertices and faces."""
    if isinstance(model, Shape):
        return model
    if hasattr(model, "vertices") and hasattr(model, "faces"):
        return MeshModel(model.vertices, model.faces)
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


def data_extent(data: Array) -> float:
    """Diagonal of the box holding the middle 96 % of the data along each axis."""
    lo, hi = np.percentile(data[:: max(1, len(data) // 5000)], [2, 98], axis=0)
    return float(np.linalg.norm(hi - lo))


def check_units(data: Array, shape: Shape) -> None:
    """Refuse data and a model whose sizes differ by a factor that only units explain."""
    size = data_extent(data)
    ratio = size / shape.extent
    if not 1.0 / _UNITS_RATIO < ratio < _UNITS_RATIO:
        guess = "mm data against a model in m" if ratio > 1 else "data in m against a model in mm"
        raise InputError(
            f"the data span {size:.4g} and the model {shape.extent:.4g} (same units): a "
            f"factor of {ratio:.3g}, which looks like {guess}; give both in the same units"
        )


def resolution_floor(data: Array, extent: float) -> float:
    """What the data can resolve without a stated noise [length units]: one part in 10,000
    of the model's size, or a hundredth of the data's point spacing if that is larger."""
    pool = data[:: max(1, len(data) // 2000)]
    if len(pool) >= 2:
        from scipy.spatial import cKDTree

        d, _ = cKDTree(pool).query(pool, k=2)
        spacing = float(np.median(d[:, 1])) * np.sqrt(len(pool) / len(data))
    else:
        spacing = 0.0
    return max(1e-4 * extent, 0.01 * spacing)


def _check_pose(T: Array, what: str) -> Array:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise InputError(f"{what} must be a finite (4, 4) matrix; got shape {T.shape}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise InputError(f"{what} must be a rigid transform: its 3 x 3 block is no rotation")
    return T


# A library entry point: its options are keyword-only, each with its default (see the
# docstring); a settings object would only move them.
def match(  # noqa: PLR0913
    data: Array,
    model: Shape | Array | object,
    *,
    mode: Mode = "auto",
    T_init: Array | None = None,
    targets: Array | None = None,
    noise: float | None = None,
    seed: int = 0,
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
        mode: "auto" (default: any coverage, from a small patch to the whole surface),
            "global" (the data cover the whole surface, eq. 9), "local" (part of it, eq. 10)
            or "refine" (ICP from T_init only: no search, so no rival is looked for).
        T_init: a guess of T_model_data (4, 4); the start of "refine", one more candidate
            in the other modes.
        targets: points (K, 3) in the model frame that the pose must locate (an operation's
            targets); the verdict is then that of the worst target, and a symmetry or a
            rival pose that leaves every target in place does not make it ambiguous.
        noise: standard deviation of the sensor's range noise [length units], if known: the
            floor of the residual scale (costs, covariance, symmetry tolerance).
        seed: seed of every random choice (subsamples); same data and seed, same result.
        variant: "point_to_plane" (default when the model has normals) or "point_to_point".
        kernel: the robust kernel of every ICP stage (the vectorised search, the ranking and
            the refinement) and of the covariance's weights; Tukey(c=8) with the floor as
            its scale's floor by default. The inlier fraction and the judging of minima
            keep Tukey's cut-off as their yardstick.
        acceptance: thresholds of the verdict.
        settings: sizes of the coarse-to-fine search.
        max_iterations: ICP iteration cap of the final refinement.
        progress: optional callable receiving one line per stage.
        passes: which scan pass each data point came from and the standard deviation of a
            pass's rigid offset (the arm's accuracy); widens the covariance accordingly.

    Returns:
        A MatchResult; poor or ambiguous matches are reported in `verdict`, not raised.
    """
    t_start = time.perf_counter()
    data, T_init, targets = _check_options(data, mode, T_init, targets, noise, seed, passes)
    shape = as_shape(model)
    check_units(data, shape)
    return _match(
        _Request(
            data=data,
            shape=shape,
            mode=mode,
            T_init=T_init,
            targets=targets,
            noise=noise,
            seed=int(seed),
            variant=variant,
            kernel=kernel,
            acceptance=acceptance or Acceptance(),
            settings=settings or SearchSettings(),
            max_iterations=max_iterations,
            say=progress or (lambda _msg: None),
            passes=passes,
            t_start=t_start,
        )
    )


def _check_options(
    data: Array,
    mode: str,
    T_init: Array | None,
    targets: Array | None,
    noise: float | None,
    seed: int,
    passes: ScanPasses | None,
) -> tuple[Array, Array | None, Array | None]:
    """The data (N, 3), T_init (4, 4) and the targets (K, 3) of `match` checked, as float
    arrays; InputError names the first input (or option) that is wrong and why."""
    if mode not in MODES:
        raise InputError(f"unknown matching mode {mode!r}; valid: {', '.join(MODES)}")
    data = check_data(data)
    if passes is not None and np.shape(passes.labels) != (len(data),):
        raise InputError(
            f"passes.labels must give one pass per data point ({len(data)}); got shape "
            f"{np.shape(passes.labels)}"
        )
    if mode == "refine" and T_init is None:
        raise InputError("mode 'refine' needs T_init, the (4, 4) initial pose")
    if T_init is not None:
        T_init = _check_pose(T_init, "T_init")
    if targets is not None:
        targets = check_points(np.atleast_2d(targets), "targets", minimum=1)
    if noise is not None and not (np.isfinite(noise) and noise > 0):
        raise InputError(f"noise must be a finite number > 0 (the sensor's sigma); got {noise}")
    if not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(f"seed must be an integer >= 0; got {seed!r}")
    return data, T_init, targets


@dataclass(frozen=True, eq=False)
class _Request:
    """A match's inputs, checked (see `match`): the data (N, 3) and the model, the options
    (defaults filled in, but the kernel, which depends on the floor), the progress callable
    and the wall time the match started at [s]."""

    data: Array
    shape: Shape
    mode: str
    T_init: Array | None
    targets: Array | None
    noise: float | None
    seed: int
    variant: Variant
    kernel: Kernel | None
    acceptance: Acceptance
    settings: SearchSettings
    max_iterations: int
    say: Progress
    passes: ScanPasses | None
    t_start: float


@dataclass(frozen=True, eq=False)
class _Work:
    """What a match works on: the model, the data points drawn (`used` (n,), indices into
    the data in the order of a coarse grid) and those points `work` (n, 3), which of them
    lie on a surface (`strict_surface` (n,)) and the fraction that lie on one loosely;
    the points the search and the refinement fit (`fit` (m, 3)) and its subsamples `mid`
    and `ranked`; the floor of the residual scale and the robust kernel; and the `reach`
    beyond which a point is an outlier of any refined pose [length units]."""

    shape: Shape
    used: Array
    work: Array
    strict_surface: Array
    surface: float
    fit: Array
    mid: Array
    ranked: Array
    floor: float
    kernel: Kernel
    reach: float

    def near(self, p: Array) -> Closest:
        """The model's closest points to `p` (N, 3) from its surface sample, within reach."""
        return self.shape.near(p, self.reach)

    def exact(self, p: Array) -> Closest:
        """The model's exact closest points to `p` (N, 3), within reach."""
        return self.shape.closest_within(p, self.reach)


def _work(request: _Request, rng: np.random.Generator) -> _Work:
    """The points the match works on, drawn from the data with `rng`, and its scales."""
    data, shape, settings = request.data, request.shape, request.settings
    extent = shape.extent
    # Random (seeded) subsamples keep the data's outlier fraction; a farthest-point sample
    # would pick the spurious points first.
    used = subsample(data, settings.refine_points, rng)
    # In the order of a coarse grid: neighbours in space are neighbours in memory, which
    # speeds up every closest-point query by about a quarter.
    cell = np.floor((data[used] - data[used].min(axis=0)) / (0.05 * extent)).astype(np.int64)
    used = used[np.lexsort(cell.T[::-1])]
    work = data[used]
    # The search and the refinement work on the points that lie on a surface; the quality
    # (inlier fraction, residuals, covariance) is computed on all of them.
    surface_of = surface_points(work, data)
    on_surface = surface_of.loose
    fit = work[on_surface] if on_surface.sum() >= 10 else work
    mid = fit[subsample(fit, settings.mid_points, rng)]
    ranked = fit[subsample(fit, settings.rank_points, rng)]
    floor = request.noise if request.noise is not None else resolution_floor(data, extent)
    return _Work(
        shape=shape,
        used=used,
        work=work,
        strict_surface=surface_of.strict,
        surface=float(on_surface.mean()),
        fit=fit,
        mid=mid,
        ranked=ranked,
        floor=floor,
        kernel=request.kernel or Tukey(min_scale=floor),
        # Points farther than this from the model are outliers of any refined pose: they
        # get a residual of `reach` instead of an exact (slow) answer.
        reach=settings.reach * extent,
    )


@dataclass(frozen=True, eq=False)
class _Quality:
    """The quality of a pose from its own residuals: RMS of the inliers' residuals, the
    inlier fraction, the fraction of the scan's surface points near the model that fit, the
    residual scale, the pose covariance (6, 6) and the worst predicted TRE over the model."""

    rms: float
    inlier_fraction: float
    surface_fit: float
    sigma: float
    covariance: Array
    worst_tre: float


def _quality(T_model_data: Array, w: _Work, seed: int, passes: ScanPasses | None) -> _Quality:
    """The quality of the pose T_model_data on the points `w.work` (N, 3) (those of them on
    a surface: `w.strict_surface` (N,)), `passes` the passes' labels of those points."""
    p = transform_points(T_model_data, w.work)
    closest = w.exact(p)
    residuals = surface_residuals(closest, p)
    inliers = fits(closest, residuals, w.floor)
    weights = closest.weights(residuals, w.kernel)
    inlier_fraction = float(inliers.mean())
    # The scan's surface points near the model (within the reach: clutter beside the object
    # is no evidence against the pose; a wrong object's surface, a few millimetres off the
    # model's, is) and the fraction of them that fit.
    near_surface = w.strict_surface & (closest.distances < w.reach)
    surface_fit = float(inliers[near_surface].mean()) if near_surface.any() else inlier_fraction
    rms = float(np.sqrt(np.mean(residuals[inliers] ** 2))) if inliers.any() else float("inf")
    dof = max(int(inliers.sum()) - 6, 1)
    sigma = float(np.sqrt(np.sum(weights * residuals**2) / max(weights.sum(), 1e-300)))
    sigma *= np.sqrt(inliers.sum() / dof) if inliers.any() else 1.0
    sigma = max(sigma, w.floor)
    correlation = residual_correlation(p[inliers], residuals[inliers], seed=seed)
    if correlation.sigma_white < w.floor:
        correlation = type(correlation)(w.floor, correlation.sigma_correlated, correlation.length)
    covariance = pose_covariance(p, closest.normals, weights, sigma, correlation, passes)
    samples = w.shape.samples
    worst_tre = float(np.max(predicted_tre(covariance, samples[:: max(1, len(samples) // 2000)])))
    return _Quality(rms, inlier_fraction, surface_fit, sigma, covariance, worst_tre)


def _rank(w: _Work, settings: SearchSettings, cap: int, poses: list[Array]) -> list[Ranked]:
    """The poses (4, 4) refined together and their residuals on `w.mid`, for the ranking.

    The robust scale is annealed from half a lookup voxel (so that a pose slid a few
    millimetres along a flat face is pulled back by the points beyond its edge): first `cap`
    iterations against the surface sample on `w.ranked`, then against the exact model, whose
    normals beyond an edge hold the scan on the face, on the smaller subsample `w.mid`."""
    T_all, _ = batched_icp(
        w.ranked, np.asarray(poses), cap, settings.trim, w.kernel, closest_pairs(w.near, w.reach),
        w.reach, anneal=0.5 * w.shape.sample_lookup.h,
    )  # fmt: skip
    T_all, _ = batched_icp(
        w.mid, T_all, settings.rank_exact_iterations, settings.trim, w.kernel,
        closest_pairs(w.exact, w.reach), w.reach,
    )  # fmt: skip
    out = []
    for T in T_all:
        p = transform_points(T, w.mid)
        c = w.exact(p)
        found = np.ones(len(p), dtype=bool) if c.found is None else c.found
        out.append(Ranked(T, surface_residuals(c, p), found))
    return out


@dataclass(frozen=True, eq=False)
class _Minima:
    """The search's outcome: the candidates (4, 4) it refined (the caller's guess last), the
    initial states it evaluated, its traces (one per search; none for "refine") and every
    minimum ranked (those of a denser search after the first's)."""

    candidates: list[Array]
    starts: int
    traces: list[Found]
    runs: list[Ranked]


def _minima(
    request: _Request, w: _Work, rng: np.random.Generator, stage: dict[str, float]
) -> _Minima:
    """The candidates of the search (or the caller's guess alone, in mode "refine"), each
    refined and ranked; searched again, denser, if no minimum fits the scan as a right pose
    does."""
    mode, settings, say = request.mode, request.settings, request.say
    traces: list[Found] = []
    if mode == "refine":
        assert request.T_init is not None
        candidates, n_starts = [request.T_init], 1
    else:
        found = search(w.fit, w.mid, w.shape, mode, settings, rng, w.kernel, stage, say)
        candidates, n_starts = found.candidates, found.starts
        traces.append(found)
        if request.T_init is not None:
            candidates.append(request.T_init)

    t0 = time.perf_counter()
    cap = min(settings.rank_iterations, request.max_iterations)
    runs = _rank(w, settings, cap, candidates)
    # A right pose fits (nearly) all of the scan's surface points, to the sensor's noise: far
    # less than a voxel of the coarse search. If no candidate does, the search may have
    # stopped in wrong minima, which fit most of a scan (sliding along a smooth region) or
    # fit all of it loosely (their robust scale as large as the misfit). Search again,
    # denser.
    scale_limit = max(settings.whole_scale * w.shape.sample_lookup.h, 2.0 * w.floor)
    best_fit = max(fitted_fraction(run, w.floor) for run in runs)
    best_scale = min(residual_scale(run, w.floor) for run in runs)
    if mode != "refine" and (best_fit < settings.whole_fit or best_scale > scale_limit):
        say(
            f"the best candidate fits {best_fit:.0%} of the scan ({w.surface:.0%} of it on a "
            f"surface), the closest to a scale of {best_scale:.3g}: searching again, denser"
        )
        again = search(w.fit, w.mid, w.shape, mode, settings.denser(), rng, w.kernel, stage, say)
        traces.append(again)
        runs += _rank(w, settings, cap, again.candidates)
        n_starts += again.starts
    stage["rank"] = time.perf_counter() - t0
    return _Minima(candidates, n_starts, traces, runs)


def _judge_rivals(
    runs: list[Ranked],
    ranking: Ranking,
    converge: Callable[[Array], tuple[IcpResult, list[Array]]],
    same_pose: Callable[[Array, Array], bool],
    judge: Judge,
    max_rivals: int,
    acceptance: Acceptance,
    floor: float,
) -> tuple[IcpResult, list[Array], float, int, list[tuple[Array, float, float]]]:
    """The best minimum of the ranked `runs`, converged, and up to `max_rivals` rivals
    judged against it (see the comment in `_judge`): the best's refinement and trajectory,
    its cost and run index (a rival that fits better takes its place), and each rival's
    pose, cost and ambiguity."""
    coarse, trajectory = converge(runs[ranking.best].T_model_data)
    best_cost, best_index = ranking.cost, ranking.best
    judged: list[tuple[Array, float, float]] = []  # rival pose, its cost, ambiguity
    for index in ranking.rivals:
        if len(judged) == max_rivals:
            break
        if floored_ratio(ranking.cost, ranking.costs[index], floor) < acceptance.max_ambiguity / 2:
            break  # this rival and the dearer ones fit far worse: none can be ambiguous
        other, other_trajectory = converge(runs[index].T_model_data)
        seen = [coarse.T_model_data, *(T for T, _, _ in judged)]
        if any(same_pose(T, other.T_model_data) for T in seen):
            continue
        # Where it converged, and where the ranking left it if that is apart from the best.
        poses = [other.T_model_data]
        if not same_pose(coarse.T_model_data, runs[index].T_model_data):
            poses.append(runs[index].T_model_data)
        judgement = judge(coarse.T_model_data, poses)
        if judgement.rival_wins and judgement.rival == 0:
            # The rival, refined, fits better: it becomes the best (and the best a rival);
            # the rivals judged so far are judged against it as they stand.
            judged = [(coarse.T_model_data, judgement.best_cost, judgement.ambiguity), *judged]
            best_cost, best_index = judgement.rival_cost, index
            coarse, trajectory = other, other_trajectory
            continue
        # Only where the ranking left it does a rival fit better: a tie at best.
        ambiguity = 1.0 if judgement.rival_wins else judgement.ambiguity
        judged.append((poses[judgement.rival], judgement.rival_cost, ambiguity))
    return coarse, trajectory, best_cost, best_index, judged


@dataclass(frozen=True, eq=False)
class _Judged:
    """The minima judged: the model's symmetries; the best minimum converged (its ICP run,
    the poses (4, 4) it went through, which the final refinement extends), its cost and its
    index among the ranked runs; the rivals with their motion from the best, the largest
    ambiguity (0 without rivals), and the most ambiguous rival as the second minimum."""

    symmetries: tuple[Symmetry, ...]
    coarse: IcpResult
    trajectory: list[Array]
    best_cost: float
    best_index: int
    rivals: tuple[Rival, ...]
    ambiguity: float
    second: Minimum | None


def _judge(request: _Request, w: _Work, runs: list[Ranked], stage: dict[str, float]) -> _Judged:
    """The model's symmetries, and the best of the ranked `runs` converged and judged
    against its rivals."""
    shape, settings, extent = w.shape, request.settings, w.shape.extent
    # The model's symmetries: found once per model (the exact operator, whose tree has been
    # built meanwhile, checks them).
    t0 = time.perf_counter()
    symmetries = find_symmetries(shape, w.floor)
    stage["symmetry"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    # What the verdict is about: the targets, or else the model's surface; and how far a
    # pose may move them and still be the same pose.
    targets = request.targets
    matters = (
        targets if targets is not None else shape.samples[:: max(1, len(shape.samples) // 500)]
    )
    tolerance = request.acceptance.tre_limit(extent)
    ranking = rank_minima(runs, settings, w.floor, symmetries, matters, tolerance)

    def converge(T: Array) -> tuple[IcpResult, list[Array]]:
        # The fast operator's answer is only as good as the sample spacing: a looser stop.
        poses: list[Array] = []
        run = icp(w.ranked, shape, T, variant=request.variant, kernel=w.kernel,
                  tau=(1e-4 * extent) ** 2, min_step=1e-5 * extent,
                  max_iterations=min(settings.converge, request.max_iterations),
                  callback=lambda _k, T, _m: poses.append(T.copy()),
                  closest=w.near)  # fmt: skip
        return run, poses

    def same_pose(T_a: Array, T_b: Array) -> bool:
        return moved_by(T_a, T_b, matters) <= tolerance or symmetric_twin(
            T_a, T_b, symmetries, matters, tolerance
        )

    # The best minimum, refined to where it converges on `rank_points` of the scan's
    # surface points (the ranking's few iterations leave a start from afar short of it);
    # then the rivals, cheapest first, each refined alike and, if it stays apart from the
    # best, judged against it where it converged and where the ranking left it. A rival
    # that converges into the best pose is none; each other one makes ambiguous the targets
    # it moves, if it fits almost as well (on a small patch of a smooth surface, poses
    # millimetres apart along a valley do; a wrong object fits in many places, each partly).
    judge = Judge(w.fit, w.exact, settings, w.floor, np.random.default_rng(request.seed + 1))
    coarse, trajectory, best_cost, best_index, judged = _judge_rivals(
        runs, ranking, converge, same_pose, judge, settings.rivals, request.acceptance, w.floor
    )
    # Each rival's motion is measured from the best as it was judged: the final refinement
    # may carry the best further along a valley, but the valley is what makes the targets
    # ambiguous.
    rivals = tuple(Rival(T @ invert(coarse.T_model_data), a) for T, _, a in judged)
    ambiguity = max((a for _, _, a in judged), default=0.0)
    second: Minimum | None = None
    if judged:
        T_second, cost_second, _ = max(judged, key=lambda j: j[2])
        second = Minimum(T_second, cost_second)
    stage["judge"] = time.perf_counter() - t0
    return _Judged(symmetries, coarse, trajectory, best_cost, best_index, rivals, ambiguity, second)


def _refine(
    request: _Request, w: _Work, judged: _Judged, stage: dict[str, float]
) -> tuple[IcpResult, Array, Minimum]:
    """The best minimum refined on `w.fit` with the exact operator (its poses appended to
    `judged.trajectory`): the run, the RMS per iteration of both refinements [length units]
    and the best minimum."""
    t0 = time.perf_counter()
    fine_run = icp(w.fit, w.shape, judged.coarse.T_model_data, variant=request.variant,
                   kernel=w.kernel, max_iterations=min(3, request.max_iterations),
                   callback=lambda _k, T, _m: judged.trajectory.append(T.copy()),
                   closest=w.exact)  # fmt: skip
    history = np.sqrt(np.concatenate([judged.coarse.mse_history, fine_run.mse_history]))
    best = Minimum(fine_run.T_model_data, judged.best_cost)
    stage["refine"] = time.perf_counter() - t0
    return fine_run, history, best


@dataclass(frozen=True, eq=False)
class _Assessment:
    """The best pose's quality, why its fit is rejected (None if it is not), the
    per-target prediction (with targets), and the verdict with its reason."""

    quality: _Quality
    fit_rejection: str | None
    targets: TargetPrediction | None
    verdict: Verdict
    reason: str


def _assess(
    request: _Request, w: _Work, T_model_data: Array, judged: _Judged, stage: dict[str, float]
) -> _Assessment:
    """The quality of the best pose T_model_data (4, 4) from its own residuals, and the
    verdict: the worst target's, or the model's without targets."""
    t0 = time.perf_counter()
    passes = request.passes
    q = _quality(T_model_data, w, request.seed,
                 None if passes is None else ScanPasses(np.asarray(passes.labels)[w.used],
                                                       passes.sigma_offset))  # fmt: skip
    extent, acceptance, targets = w.shape.extent, request.acceptance, request.targets
    fit_reason = fit_rejection(q.rms, q.inlier_fraction, q.surface_fit, extent, acceptance)
    prediction = None
    if targets is not None:
        prediction = assess_targets(
            targets, predicted_tre(q.covariance, targets), fit_reason, judged.symmetries,
            judged.rivals, extent, acceptance,
        )  # fmt: skip
        verdict, reason = _worst_target(prediction.verdict, prediction.reason)
    else:
        verdict, reason = model_verdict(
            fit_reason, judged.symmetries, judged.ambiguity, q.worst_tre,
            request.mode != "refine", extent, acceptance,
        )  # fmt: skip
    stage["quality"] = time.perf_counter() - t0
    return _Assessment(q, fit_reason, prediction, verdict, reason)


def _match(request: _Request) -> MatchResult:
    """The match the request asks for, step by step (see the module's docstring)."""
    stage: dict[str, float] = {}
    rng = np.random.default_rng(request.seed)
    w = _work(request, rng)
    minima = _minima(request, w, rng, stage)
    judged = _judge(request, w, minima.runs, stage)
    fine_run, history, best = _refine(request, w, judged, stage)
    request.say(f"ranked {len(minima.runs)} minima; the best refined on {len(w.fit)} points")
    assessment = _assess(request, w, best.T_model_data, judged, stage)
    q = assessment.quality
    turns = tuple(s.motion() @ best.T_model_data for s in judged.symmetries if s.kind == "turn")
    request.say(f"{assessment.verdict}: {assessment.reason}")
    return MatchResult(
        T_model_data=best.T_model_data,
        rms=q.rms,
        inlier_fraction=q.inlier_fraction,
        surface_fit=q.surface_fit,
        sigma=q.sigma,
        iterations=len(history),
        converged=fine_run.converged,
        history=history,
        trajectory=np.asarray(judged.trajectory),
        mode=request.mode,
        starts=minima.starts,
        best=best,
        second=judged.second,
        rivals=judged.rivals,
        ambiguity=float(judged.ambiguity),
        covariance=q.covariance,
        worst_predicted_tre=q.worst_tre,
        symmetries=judged.symmetries,
        equivalent_poses=turns,
        floor=float(w.floor),
        verdict=assessment.verdict,
        reason=assessment.reason,
        targets=assessment.targets,
        points_used=len(w.work),
        seed=request.seed,
        acceptance=request.acceptance,
        extent=w.shape.extent,
        fit_rejection=assessment.fit_rejection,
        seconds=time.perf_counter() - request.t_start,
        stage_seconds=stage,
        search=_trace(
            minima.traces, minima.candidates, minima.runs[judged.best_index].T_model_data
        ),
    )


def _worst_target(verdicts: tuple[str, ...], reasons: tuple[str, ...]) -> tuple[Verdict, str]:
    """The overall verdict with targets: the worst target's, with its reason."""
    for level in ("rejected", "ambiguous"):
        bad = [k for k, v in enumerate(verdicts) if v == level]
        if bad:
            return level, f"target {bad[0]}: {reasons[bad[0]]}" + (
                f" ({len(bad)} of {len(verdicts)} targets {level})" if len(bad) > 1 else ""
            )
    return "accepted", f"all {len(verdicts)} targets located: good fit, well-constrained pose"


def _trace(traces: list[Found], candidates: list[Array], T_best: Array) -> SearchTrace:
    """The search's trace (one or two searches, or a refinement's single start)."""
    if not traces:
        start = np.asarray(candidates)
        return SearchTrace(start, np.zeros(len(start)), start, np.zeros(len(start)), T_best)
    return SearchTrace(
        np.concatenate([f.start_poses for f in traces]),
        np.concatenate([f.start_costs for f in traces]),
        np.concatenate([f.minima for f in traces]),
        np.concatenate([f.minima_costs for f in traces]),
        T_best,
    )
