"""Ranking the refined minima and judging the two best against each other.

The minima are ranked on one subsample of the data, by the RMS of as large a fraction of
their residuals as the best pose fits: a wrong pose that slides along a smooth region may fit
a large share of the scan, but not all of it. A minimum that differs from the best only by a
symmetry of the model is no rival but the same pose (the symmetry is reported instead). The
two best are then compared on a larger subsample with the exact closest-point operator.

Costs are compared with the floor added in quadrature: two perfect fits (residuals at
rounding level) are a tie, not a ratio of rounding errors.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from registration.kernels import Tukey
from registration.quality import trimmed_rms
from registration.rigid import Array, invert, transform_points
from registration.search import SearchSettings, subsample
from registration.shapes.base import Closest
from registration.symmetry import Symmetry


@dataclass(frozen=True)
class Ranked:
    """A candidate refined for the ranking: its pose (4, 4), its residuals (n,) on the
    ranking subsample, and which of those points found the surface within the reach (n,)."""

    T_model_data: Array
    residuals: Array
    found: Array


@dataclass(frozen=True)
class Ranking:
    """The best minimum and its rivals among the refined runs.

    Attributes:
        best: index of the best run; cost: its cost.
        rivals: indices of the runs that would be a rival (see `rank_minima`), cheapest
            first.
        costs: every run's cost (on the fraction the best fits).
        fitted: fraction of the subsample the best run fits.
    """

    best: int
    cost: float
    rivals: tuple[int, ...]
    costs: Array
    fitted: float


def residual_scale(run: Ranked, floor: float) -> float:
    """Robust scale of the residuals of a run's points that found the surface (Tukey's S:
    the median absolute deviation), at least the floor; inf if none did."""
    if not run.found.any():
        return float("inf")
    return float(Tukey(min_scale=floor).scale(run.residuals[run.found]))


def fits(closest: Closest, residuals: Array, floor: float) -> Array:
    """(n,) True for the points that fit: they found the surface, and their residual is
    within Tukey's cut-off (c = 8) of the robust scale of those that did (at least the
    floor)."""
    return closest.weights(residuals, Tukey(min_scale=floor)) > 0


def fitted_fraction(run: Ranked, floor: float) -> float:
    """Fraction of a run's points that fit (see `fits`)."""
    closest = Closest(np.empty((0, 3)), None, np.empty(0), run.found)
    return float(np.mean(fits(closest, run.residuals, floor)))


def symmetric_twin(
    T_a: Array, T_b: Array, symmetries: Sequence[Symmetry], matters: Array, tolerance: float
) -> bool:
    """True if pose T_b is pose T_a moved by one of the model's symmetries: the nearest
    motion of a symmetry puts the points that matter (K, 3) within `tolerance` of where
    T_b puts them."""
    M = T_b @ invert(T_a)
    return any(moved_by(s.closest_motion(M), M, matters) <= tolerance for s in symmetries)


def moved_by(T_a: Array, T_b: Array, points: Array) -> float:
    """How far (the largest distance) the motion from pose T_a to pose T_b (4, 4) moves the
    points (K, 3) of the model frame that matter."""
    M = T_b @ invert(T_a)
    return float(np.max(np.linalg.norm(transform_points(M, points) - points, axis=1)))


def rank_minima(
    runs: Sequence[Ranked],
    settings: SearchSettings,
    floor: float,
    symmetries: Sequence[Symmetry],
    matters: Array,
    tolerance: float,
) -> Ranking:
    """Rank the refined runs (all on one subsample) and find the rivals: the runs that move
    a point that matters (K, 3) (the targets, or the model) by more than `tolerance` from
    where the best puts it, and are not the best moved by a symmetry of the model.

    A run that moves them by less is the same pose as far as the verdict goes; one that
    lies further along a valley of the cost is a rival: on a small patch of a smooth
    surface, starts end millimetres apart, and none of them is located."""
    costs = np.array([float(trimmed_rms(run.residuals, settings.trim)) for run in runs])
    best = int(np.argmin(costs))
    fitted = fitted_fraction(runs[best], floor)
    trim = float(np.clip(fitted - 0.05, settings.trim, 0.95))
    costs = np.array([float(trimmed_rms(run.residuals, trim)) for run in runs])
    best = int(np.argmin(costs))
    T_best = runs[best].T_model_data
    rivals = tuple(
        int(i)
        for i in np.argsort(costs, kind="stable")
        if moved_by(T_best, runs[int(i)].T_model_data, matters) > tolerance
        and not symmetric_twin(T_best, runs[int(i)].T_model_data, symmetries, matters, tolerance)
    )
    return Ranking(best, float(costs[best]), rivals, costs, fitted)


def _found(closest: Closest, n: int) -> Array:
    """(n,) which points found the surface (all, if the operator says nothing)."""
    return np.ones(n, dtype=bool) if closest.found is None else closest.found


def surface_residuals(closest: Closest, p: Array) -> Array:
    """Point-to-plane residuals (N,) of points (N, 3) in the model frame from their closest
    points on the model (distances if the shape has no normals)."""
    if closest.normals is None:
        return closest.distances
    return np.einsum("nd,nd->n", closest.normals, p - closest.points)


@dataclass(frozen=True)
class Judgement:
    """The best minimum judged against its rival.

    Attributes:
        rival: which of the rival's poses was the most competitive (an index into the
            poses given).
        rival_wins: that pose fits the scan better than the best.
        best_cost, rival_cost: their costs on the judging subsample [length units].
        ambiguity: the ratio of the winner's cost to the loser's, the floor added to both
            (0 if the loser leaves clearly more of the scan unexplained).
    """

    rival: int
    rival_wins: bool
    best_cost: float
    rival_cost: float
    ambiguity: float


class Judge:
    """Judges the best minimum against rivals on one subsample of `judge_points` of the
    data (drawn once), with the closest-point operator given; the best pose's residuals
    are computed once per best pose.

    On a few hundred points, a pose that leaves a few per cent of the scan unexplained (a
    part slid along its extrusion, the legs of an L swapped) scores like the true one once
    the ranking trims its worst points. On `judge_points`, the points each pose explains are
    counted with one yardstick (Tukey's cut-off at the robust scale of the better pose). A
    pose that explains more than `judge_unexplained` more of the scan, and leaves at most
    half as much of it unexplained, wins, and the other is no rival (ambiguity 0). Otherwise
    both are costed on the largest fraction either explains, less `judge_margin` (the
    points where they differ; on the `trim` fraction alone the part they share would
    decide): the cheaper wins, and the ambiguity is the ratio of their costs (the floor
    added to both). A refinement minimises its own robust cost, not this one: a rival can
    lose ground to the best by converging, so a rival may be given as several poses (where
    it converged, where the ranking left it) and counts at its most competitive.
    """

    def __init__(
        self,
        data: Array,
        closest: Callable[[Array], Closest],
        settings: SearchSettings,
        floor: float,
        rng: np.random.Generator,
    ) -> None:
        self.points = data[subsample(data, settings.judge_points, rng)]
        self.closest = closest
        self.settings = settings
        self.floor = floor
        self._best: tuple[bytes, tuple[Array, Array]] | None = None

    def residuals(self, T: Array) -> tuple[Array, Array]:
        """Absolute residuals (n,) of the subsample under pose T, and which found the
        surface (n,)."""
        p = transform_points(T, self.points)
        c = self.closest(p)
        return np.abs(surface_residuals(c, p)), _found(c, len(p))

    def __call__(self, T_best: Array, T_rival: Sequence[Array]) -> Judgement:
        key = np.asarray(T_best).tobytes()
        if self._best is None or self._best[0] != key:
            self._best = (key, self.residuals(T_best))
        best = self._best[1]
        outcomes = [_compare(best, self.residuals(T), self.settings, self.floor) for T in T_rival]
        # The rival's most competitive pose: one that wins, else the most ambiguous.
        k = max(range(len(outcomes)), key=lambda i: (outcomes[i][0], outcomes[i][3]))
        wins, cost_best, cost_rival, ambiguity = outcomes[k]
        return Judgement(k, wins, cost_best, cost_rival, ambiguity)


def _compare(
    best: tuple[Array, Array], rival: tuple[Array, Array], settings: SearchSettings, floor: float
) -> tuple[bool, float, float, float]:
    """(rival wins, best's cost, rival's cost, ambiguity) of two poses' absolute residuals
    and found masks on the same points."""
    residuals, found = (best[0], rival[0]), (best[1], rival[1])
    costs = [float(trimmed_rms(r, settings.trim)) for r in residuals]
    better = int(np.argmin(costs))
    run = Ranked(np.eye(4), residuals[better], found[better])
    cut = Tukey(min_scale=floor).c * residual_scale(run, floor)
    explained = [float(np.mean((r <= cut) & f)) for r, f in zip(residuals, found, strict=True)]
    more, less = sorted(explained, reverse=True)
    if more - less > settings.judge_unexplained and 1.0 - more <= (1.0 - less) / 2:
        first = int(np.argmax(explained))
        return first == 1, costs[0], costs[1], 0.0
    # Compared on as much of the scan as either explains: where they differ.
    trim = float(np.clip(more - settings.judge_margin, settings.trim, 0.99))
    costs = [float(trimmed_rms(r, trim)) for r in residuals]
    first = int(np.argmin(costs))
    return first == 1, costs[0], costs[1], floored_ratio(costs[first], costs[1 - first], floor)


def floored_ratio(best: float, other: float, floor: float) -> float:
    """sqrt(best^2 + floor^2) / sqrt(other^2 + floor^2), at most 1."""
    return float(min(1.0, np.hypot(best, floor) / max(np.hypot(other, floor), 1e-300)))
