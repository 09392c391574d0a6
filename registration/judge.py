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
from registration.search import SearchSettings, displacement, subsample
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
    """The best minimum and its rival among the refined runs.

    Attributes:
        best: index of the best run; cost: its cost.
        second: index of the best run distinct from it (and not a symmetric twin), or None.
        second_cost: that run's cost (inf if none).
        fitted: fraction of the subsample the best run fits.
    """

    best: int
    cost: float
    second: int | None
    second_cost: float
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
    T_a: Array, T_b: Array, symmetries: Sequence[Symmetry], points_model: Array, limit: float
) -> bool:
    """True if pose T_b is pose T_a moved by one of the model's symmetries (within `limit`,
    the RMS displacement of `points_model` (N, 3))."""
    M = T_b @ invert(T_a)
    return any(displacement(M, s.closest_motion(M), points_model) <= limit for s in symmetries)


def rank_minima(
    runs: Sequence[Ranked],
    mid: Array,
    extent: float,
    settings: SearchSettings,
    floor: float,
    symmetries: Sequence[Symmetry],
) -> Ranking:
    """Rank the refined runs (all on the subsample `mid` (n, 3)) and find the rival."""
    costs = np.array([float(trimmed_rms(run.residuals, settings.trim)) for run in runs])
    best = int(np.argmin(costs))
    fitted = fitted_fraction(runs[best], floor)
    trim = float(np.clip(fitted - 0.05, settings.trim, 0.95))
    costs = np.array([float(trimmed_rms(run.residuals, trim)) for run in runs])
    best = int(np.argmin(costs))
    T_best = runs[best].T_model_data
    points_model = transform_points(T_best, mid)
    limit = settings.distinct * extent
    for i in np.argsort(costs, kind="stable"):
        T_i = runs[int(i)].T_model_data
        if displacement(T_i, T_best, mid) <= limit:
            continue
        if symmetric_twin(T_best, T_i, symmetries, points_model, limit):
            continue
        return Ranking(best, float(costs[best]), int(i), float(costs[int(i)]), fitted)
    return Ranking(best, float(costs[best]), None, float("inf"), fitted)


def _found(closest: Closest, n: int) -> Array:
    """(n,) which points found the surface (all, if the operator says nothing)."""
    return np.ones(n, dtype=bool) if closest.found is None else closest.found


def surface_residuals(closest: Closest, p: Array) -> Array:
    """Point-to-plane residuals (N,) of points (N, 3) in the model frame from their closest
    points on the model (distances if the shape has no normals)."""
    if closest.normals is None:
        return closest.distances
    return np.einsum("nd,nd->n", closest.normals, p - closest.points)


def judge(
    data: Array,
    closest: Callable[[Array], Closest],
    T_best: Array,
    T_other: Array,
    settings: SearchSettings,
    floor: float,
    rng: np.random.Generator,
) -> tuple[int, float, float, float]:
    """The two best minima compared on a larger subsample of the data.

    On a few hundred points, a pose that leaves a few per cent of the scan unexplained (a
    part slid along its extrusion, the legs of an L swapped) scores like the true one once
    the ranking trims its worst points. On `judge_points`, the points each pose explains are
    counted with one yardstick (Tukey's cut-off at the robust scale of the better pose). A
    pose that explains more than `judge_unexplained` more of the scan, and leaves at most
    half as much of it unexplained, wins, and the other is no rival (ambiguity 0). Otherwise
    both are costed on the largest fraction either explains, less `judge_margin` (the
    points where they differ; on the `trim` fraction alone the part they share would
    decide): the cheaper wins, and the ambiguity is the ratio of their costs (the floor
    added to both). The poses are judged as given (the matcher refines them first, where
    they stay distinct).

    Returns which pose wins (0: T_best, 1: T_other), its cost, the other's cost and the
    ambiguity.
    """
    points = data[subsample(data, settings.judge_points, rng)]
    poses = (T_best, T_other)
    moved = [transform_points(T, points) for T in poses]
    found = [closest(p) for p in moved]
    residuals = [np.abs(surface_residuals(c, p)) for c, p in zip(found, moved, strict=True)]
    costs = [float(trimmed_rms(r, settings.trim)) for r in residuals]
    better = int(np.argmin(costs))
    run = Ranked(poses[better], residuals[better], _found(found[better], len(points)))
    tukey = Tukey(min_scale=floor)
    cut = tukey.c * residual_scale(run, floor)
    explained = [
        float(np.mean((r <= cut) & _found(c, len(points))))
        for c, r in zip(found, residuals, strict=True)
    ]
    more, less = sorted(explained, reverse=True)
    if more - less > settings.judge_unexplained and 1.0 - more <= (1.0 - less) / 2:
        first = int(np.argmax(explained))
        return first, costs[first], costs[1 - first], 0.0
    # Compared on as much of the scan as either explains: where they differ.
    trim = float(np.clip(more - settings.judge_margin, settings.trim, 0.99))
    costs = [float(trimmed_rms(r, trim)) for r in residuals]
    first = int(np.argmin(costs))
    return (
        first,
        costs[first],
        costs[1 - first],
        floored_ratio(costs[first], costs[1 - first], floor),
    )


def floored_ratio(best: float, other: float, floor: float) -> float:
    """sqrt(best^2 + floor^2) / sqrt(other^2 + floor^2), at most 1."""
    return float(min(1.0, np.hypot(best, floor) / max(np.hypot(other, floor), 1e-300)))
