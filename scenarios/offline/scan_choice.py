"""The scan planner's greedy choice of passes (scenarios.offline.scan_plan): at each step
the candidate that lowers the worst predicted TRE at the targets most per second of its cell
time, until every target is below the goal, the time budget is spent, or no pass gains
enough; and the record of each pass chosen (`ChosenPass`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from scenarios.offline.scan_candidates import Candidate
from scenarios.offline.tre_prediction import ErrorModel, information_shares, predict_tre

Progress = Callable[[str], None]


@dataclass(frozen=True)
class ChosenPass:
    """A chosen pass: its name, parameters (`standoff_m` None: the scan's own), the worst
    predicted TRE [m] once it is added, its cell time [s] and its share of the plan's
    information (the trace of the information matrix it adds, over the plan's)."""

    name: str
    tilt_deg: float
    heading_deg: float
    offset_m: float
    standoff_m: float | None
    table_position_m: float
    predicted_tre_max_m: float
    seconds: float
    information_share: float


def _best_candidate(
    chosen: list[Candidate],
    left: list[Candidate],
    tre: np.ndarray,
    spent_s: float,
    budget_s: float,
    targets_model: np.ndarray,
    errors: ErrorModel,
) -> tuple[Candidate | None, np.ndarray, float]:
    """The candidate among `left` that lowers the worst predicted TRE most per second of
    cell time added to `chosen` (predicted TRE (K,) [m] now `tre`; while nothing constrains
    every target, the one that sees most per second), within `budget_s` [s] with `spent_s`
    spent once a pass is chosen: it (None if none fits), the predicted TRE with it, and the
    most any one pass lowers the worst predicted TRE [m]."""
    best, best_gain, best_tre = None, -np.inf, tre
    worst_now = float(np.max(tre))
    largest_drop = 0.0
    for c in left:
        if chosen and spent_s + c.seconds > budget_s:
            continue
        t, _ = predict_tre([*chosen, c], targets_model, errors)
        worst = float(np.max(t))
        if np.isfinite(worst) and np.isfinite(worst_now):
            largest_drop = max(largest_drop, worst_now - worst)
        if not np.isfinite(worst):
            gain = -np.inf if np.isfinite(worst_now) else len(c.points_model) / c.seconds
            gain = gain * 1e-12  # constrains nothing yet: coverage first
        elif not np.isfinite(worst_now):
            gain = 1.0 / (worst * c.seconds)
        else:
            gain = (worst_now - worst) / c.seconds
        if gain > best_gain:
            best, best_gain, best_tre = c, gain, t
    return best, best_tre, largest_drop


def choose_passes(
    found: tuple[Candidate, ...],
    targets_model: np.ndarray,
    errors: ErrorModel,
    goal_m: float,
    budget_s: float,
    say: Progress | None = None,
    unambiguous: Callable[[list[Candidate]], bool] | None = None,
    min_gain: float = 0.0,
    enough_points: Callable[[list[Candidate]], bool] | None = None,
) -> tuple[list[Candidate], list[ChosenPass], np.ndarray, bool]:
    """Greedy choice (see the module's docstring): the passes, their records, the predicted
    TRE (K,) [m] of the plan, and whether `unambiguous(passes)` holds for it (the match of
    the points they would see finds one pose; passes are added until it does). Passes are
    also added while `enough_points(passes)` does not hold (the match needs that many of
    the object's points). Short of the goal, the choice also stops when no pass lowers the
    worst predicted TRE by the fraction `min_gain` of it: more scanning would buy next to
    nothing."""
    chosen: list[Candidate] = []
    records: list[ChosenPass] = []
    tre, spent, left, unique = np.full(len(targets_model), np.inf), 0.0, list(found), False
    tell = say or (lambda _m: None)

    def done() -> bool:
        nonlocal unique
        if not chosen or np.max(tre) > goal_m:
            return False
        if enough_points is not None and not enough_points(chosen):
            tell("scan plan: these passes see fewer of the object's points than needed: one more")
            return False
        unique = unambiguous is None or unambiguous(chosen)
        if not unique:
            tell("scan plan: the match of what these passes see is ambiguous: one more pass")
        return unique

    while left and not done():
        worst_now = float(np.max(tre))
        best, best_tre, largest_drop = _best_candidate(
            chosen, left, tre, spent, budget_s, targets_model, errors
        )
        if best is None:
            break
        if np.isfinite(worst_now) and worst_now > goal_m and largest_drop < min_gain * worst_now:
            tell(
                f"scan plan: no pass lowers the worst predicted TRE by {min_gain:.0%} any more: "
                "the plan stops here"
            )
            break
        chosen.append(best)
        left.remove(best)
        spent += best.seconds
        tre = best_tre
        records.append(
            ChosenPass(
                best.planned.name,
                best.spec.tilt_deg,
                best.spec.heading_deg,
                best.spec.offset_m,
                best.spec.standoff_m,
                best.planned.table_position_m,
                float(np.max(tre)),
                best.seconds,
                0.0,
            )
        )
        tell(
            f"scan plan: + {best.planned.name}: worst predicted TRE "
            f"{np.max(tre) * 1e3:.3f} mm, {spent:.0f} s"
        )
    shares = information_shares(chosen, targets_model, errors)
    records = [
        ChosenPass(**{**r.__dict__, "information_share": s})
        for r, s in zip(records, shares, strict=True)
    ]
    if not unique and chosen:
        unique = unambiguous is None or unambiguous(chosen)
    return chosen, records, tre, unique
