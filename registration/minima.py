"""The minima of a match: the search's candidates refined and ranked, and the best judged.

Step 2 of `match` (matcher.py): each candidate of the search refined by ICP on a subsample
of the data, the minima ranked (searched again, denser, if none fits the scan as a right
pose does), and the best converged and judged against its rivals (judge.py); a minimum that
differs from the best by a symmetry of the model (symmetry.py) is the same pose, not a rival.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from registration.icp import IcpResult, icp
from registration.judge import (
    Judge,
    Ranked,
    Ranking,
    fitted_fraction,
    floored_ratio,
    moved_by,
    rank_minima,
    residual_scale,
    surface_residuals,
    symmetric_twin,
)
from registration.match_request import MatchRequest
from registration.match_work import MatchWork
from registration.result import Minimum
from registration.rigid import Array, invert, transform_points
from registration.search import Found, SearchSettings, batched_icp, closest_pairs, search
from registration.symmetry import Symmetry, find_symmetries
from registration.verdict import Acceptance, Rival


def _rank(w: MatchWork, settings: SearchSettings, cap: int, poses: list[Array]) -> list[Ranked]:
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
class Minima:
    """The search's outcome: the candidates (4, 4) it refined (the caller's guess last), the
    initial states it evaluated, its traces (one per search; none for "refine") and every
    minimum ranked (those of a denser search after the first's)."""

    candidates: list[Array]
    starts: int
    traces: list[Found]
    runs: list[Ranked]


def find_minima(
    request: MatchRequest, w: MatchWork, rng: np.random.Generator, stage: dict[str, float]
) -> Minima:
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
    return Minima(candidates, n_starts, traces, runs)


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
class Judged:
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


def judge_minima(
    request: MatchRequest, w: MatchWork, runs: list[Ranked], stage: dict[str, float]
) -> Judged:
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
    return Judged(symmetries, coarse, trajectory, best_cost, best_index, rivals, ambiguity, second)
