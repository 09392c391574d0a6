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
from registration.symmetry import find_symmetries
from registration.verdict import (
    Acceptance,
    Rival,
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


def match(
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
    shape = as_shape(model)
    check_units(data, shape)
    settings = settings or SearchSettings()
    acceptance = acceptance or Acceptance()
    say = progress or (lambda _msg: None)
    return _match(
        data, shape, mode, T_init, targets, noise, int(seed), variant, kernel,
        acceptance, settings, max_iterations, say, passes, t_start,
    )  # fmt: skip


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


def _quality(
    T_model_data: Array,
    work: Array,
    exact: Callable[[Array], Closest],
    kernel: Kernel,
    floor: float,
    strict_surface: Array,
    reach: float,
    shape: Shape,
    seed: int,
    passes: ScanPasses | None,
) -> _Quality:
    """The quality of the pose T_model_data on the points `work` (N, 3) (those of them on a
    surface: `strict_surface` (N,)), `passes` the passes' labels of those points."""
    p = transform_points(T_model_data, work)
    closest = exact(p)
    residuals = surface_residuals(closest, p)
    inliers = fits(closest, residuals, floor)
    weights = closest.weights(residuals, kernel)
    inlier_fraction = float(inliers.mean())
    # The scan's surface points near the model (within the reach: clutter beside the object
    # is no evidence against the pose; a wrong object's surface, a few millimetres off the
    # model's, is) and the fraction of them that fit.
    near_surface = strict_surface & (closest.distances < reach)
    surface_fit = float(inliers[near_surface].mean()) if near_surface.any() else inlier_fraction
    rms = float(np.sqrt(np.mean(residuals[inliers] ** 2))) if inliers.any() else float("inf")
    dof = max(int(inliers.sum()) - 6, 1)
    sigma = float(np.sqrt(np.sum(weights * residuals**2) / max(weights.sum(), 1e-300)))
    sigma *= np.sqrt(inliers.sum() / dof) if inliers.any() else 1.0
    sigma = max(sigma, floor)
    correlation = residual_correlation(p[inliers], residuals[inliers], seed=seed)
    if correlation.sigma_white < floor:
        correlation = type(correlation)(floor, correlation.sigma_correlated, correlation.length)
    covariance = pose_covariance(p, closest.normals, weights, sigma, correlation, passes)
    worst_tre = float(
        np.max(predicted_tre(covariance, shape.samples[:: max(1, len(shape.samples) // 2000)]))
    )
    return _Quality(rms, inlier_fraction, surface_fit, sigma, covariance, worst_tre)


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
    judged against it (see the comment in `_match`): the best's refinement and trajectory,
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


def _match(
    data: Array,
    shape: Shape,
    mode: str,
    T_init: Array | None,
    targets: Array | None,
    noise: float | None,
    seed: int,
    variant: Variant,
    kernel: Kernel | None,
    acceptance: Acceptance,
    settings: SearchSettings,
    max_iterations: int,
    say: Progress,
    passes: ScanPasses | None,
    t_start: float,
) -> MatchResult:
    extent = shape.extent
    stage: dict[str, float] = {}
    rng = np.random.default_rng(seed)
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
    surface = float(on_surface.mean())
    fit = work[on_surface] if on_surface.sum() >= 10 else work
    mid = fit[subsample(fit, settings.mid_points, rng)]
    ranked = fit[subsample(fit, settings.rank_points, rng)]
    floor = noise if noise is not None else resolution_floor(data, extent)
    kernel = kernel or Tukey(min_scale=floor)
    # Points farther than this from the model are outliers of any refined pose: they get a
    # residual of `reach` instead of an exact (slow) answer.
    reach = settings.reach * extent

    def near(p: Array) -> Closest:
        return shape.near(p, reach)

    def exact(p: Array) -> Closest:
        return shape.closest_within(p, reach)

    traces: list[Found] = []
    if mode == "refine":
        assert T_init is not None
        candidates, n_starts = [T_init], 1
    else:
        found = search(fit, mid, shape, mode, settings, rng, kernel, stage, say)
        candidates, n_starts = found.candidates, found.starts
        traces.append(found)
        if T_init is not None:
            candidates.append(T_init)

    t0 = time.perf_counter()
    cap = min(settings.rank_iterations, max_iterations)

    def rank(poses: list[Array]) -> list[Ranked]:
        # All candidates refined together, the robust scale annealed from half a lookup
        # voxel (so that a pose slid a few millimetres along a flat face is pulled back by
        # the points beyond its edge), first against the surface sample on `rank_points`,
        # then against the exact model, whose normals beyond an edge hold the scan on the
        # face, on the smaller subsample that ranks them.
        T_all, _ = batched_icp(
            ranked, np.asarray(poses), cap, settings.trim, kernel, closest_pairs(near, reach),
            reach, anneal=0.5 * shape.sample_lookup.h,
        )  # fmt: skip
        T_all, _ = batched_icp(
            mid, T_all, settings.rank_exact_iterations, settings.trim, kernel,
            closest_pairs(exact, reach), reach,
        )  # fmt: skip
        out = []
        for T in T_all:
            p = transform_points(T, mid)
            c = exact(p)
            found = np.ones(len(p), dtype=bool) if c.found is None else c.found
            out.append(Ranked(T, surface_residuals(c, p), found))
        return out

    runs = rank(candidates)
    # A right pose fits (nearly) all of the scan's surface points, to the sensor's noise: far
    # less than a voxel of the coarse search. If no candidate does, the search may have
    # stopped in wrong minima, which fit most of a scan (sliding along a smooth region) or
    # fit all of it loosely (their robust scale as large as the misfit). Search again,
    # denser.
    scale_limit = max(settings.whole_scale * shape.sample_lookup.h, 2.0 * floor)
    best_fit = max(fitted_fraction(run, floor) for run in runs)
    best_scale = min(residual_scale(run, floor) for run in runs)
    if mode != "refine" and (best_fit < settings.whole_fit or best_scale > scale_limit):
        say(
            f"the best candidate fits {best_fit:.0%} of the scan ({surface:.0%} of it on a "
            f"surface), the closest to a scale of {best_scale:.3g}: searching again, denser"
        )
        again = search(fit, mid, shape, mode, settings.denser(), rng, kernel, stage, say)
        more, n_more = again.candidates, again.starts
        traces.append(again)
        runs += rank(more)
        n_starts += n_more
    stage["rank"] = time.perf_counter() - t0
    # The model's symmetries: found once per model (the exact operator, whose tree has been
    # built meanwhile, checks them).
    t0 = time.perf_counter()
    symmetries = find_symmetries(shape, floor)
    stage["symmetry"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    # What the verdict is about: the targets, or else the model's surface; and how far a
    # pose may move them and still be the same pose.
    matters = (
        targets if targets is not None else shape.samples[:: max(1, len(shape.samples) // 500)]
    )
    tolerance = acceptance.tre_limit(extent)
    ranking = rank_minima(runs, settings, floor, symmetries, matters, tolerance)

    def converge(T: Array) -> tuple[IcpResult, list[Array]]:
        # The fast operator's answer is only as good as the sample spacing: a looser stop.
        poses: list[Array] = []
        run = icp(ranked, shape, T, variant=variant, kernel=kernel, tau=(1e-4 * extent) ** 2,
                  min_step=1e-5 * extent, max_iterations=min(settings.converge, max_iterations),
                  callback=lambda _k, T, _m: poses.append(T.copy()),
                  closest=near)  # fmt: skip
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
    judge = Judge(fit, exact, settings, floor, np.random.default_rng(seed + 1))
    coarse, trajectory, best_cost, best_index, judged = _judge_rivals(
        runs, ranking, converge, same_pose, judge, settings.rivals, acceptance, floor
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

    t0 = time.perf_counter()
    fine_run = icp(fit, shape, coarse.T_model_data, variant=variant, kernel=kernel,
                   max_iterations=min(3, max_iterations),
                   callback=lambda _k, T, _m: trajectory.append(T.copy()),
                   closest=exact)  # fmt: skip
    history = np.sqrt(np.concatenate([coarse.mse_history, fine_run.mse_history]))
    best = Minimum(fine_run.T_model_data, best_cost)
    stage["refine"] = time.perf_counter() - t0
    say(f"ranked {len(runs)} minima; the best refined on {len(fit)} points")

    # Quality of the best pose, from its own residuals.
    t0 = time.perf_counter()
    q = _quality(best.T_model_data, work, exact, kernel, floor, surface_of.strict, reach,
                 shape, seed,
                 None if passes is None else ScanPasses(np.asarray(passes.labels)[used],
                                                       passes.sigma_offset))  # fmt: skip
    rms, inlier_fraction, surface_fit, sigma = q.rms, q.inlier_fraction, q.surface_fit, q.sigma
    covariance, worst_tre = q.covariance, q.worst_tre
    fit_reason = fit_rejection(rms, inlier_fraction, surface_fit, extent, acceptance)
    prediction = None
    if targets is not None:
        prediction = assess_targets(
            targets, predicted_tre(covariance, targets), fit_reason, symmetries, rivals,
            extent, acceptance,
        )  # fmt: skip
        verdict, reason = _worst_target(prediction.verdict, prediction.reason)
    else:
        verdict, reason = model_verdict(
            fit_reason, symmetries, ambiguity, worst_tre, mode != "refine", extent, acceptance
        )
    stage["quality"] = time.perf_counter() - t0
    turns = tuple(s.motion() @ best.T_model_data for s in symmetries if s.kind == "turn")
    say(f"{verdict}: {reason}")
    return MatchResult(
        T_model_data=best.T_model_data,
        rms=rms,
        inlier_fraction=inlier_fraction,
        surface_fit=surface_fit,
        sigma=sigma,
        iterations=len(history),
        converged=fine_run.converged,
        history=history,
        trajectory=np.asarray(trajectory),
        mode=mode,
        starts=n_starts,
        best=best,
        second=second,
        rivals=rivals,
        ambiguity=float(ambiguity),
        covariance=covariance,
        worst_predicted_tre=worst_tre,
        symmetries=symmetries,
        equivalent_poses=turns,
        floor=float(floor),
        verdict=verdict,
        reason=reason,
        targets=prediction,
        points_used=len(work),
        seed=seed,
        acceptance=acceptance,
        extent=extent,
        fit_rejection=fit_reason,
        seconds=time.perf_counter() - t_start,
        stage_seconds=stage,
        search=_trace(traces, candidates, runs[best_index].T_model_data),
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
