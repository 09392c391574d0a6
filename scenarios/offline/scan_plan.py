"""Scan planning aimed at the targets: candidate passes simulated in the virtual cell, chosen
for the worst predicted target error per second of scan.

Each candidate is a straight pass (`ScanPass`: tilt, heading, aim offset) around the object's
upper hemisphere and sides. It is kept if the arm follows it at some table position and the
laser clears the object and the cell along it; then its lines are ray cast in the virtual
cell (the nominal model at its believed pose, the laser's data sheet: rays, range, grazing
limit) for the surface it would see, and its cell time is its sweep plus the arm's moves to
and from it.

The planner adds passes greedily: at each step the one that lowers the worst predicted TRE
at the operation targets most per second of its cell time. The predicted TRE is the
registration's (registration.quality.pose_covariance): the point-to-plane information of the
points the passes would see, thinned as the match thins them, with correlated model error
and each pass's rigid offset (the arm's accuracy) from the configuration's data-sheet
numbers. It stops when every target is below the goal or the time budget is spent. A target
that no reachable pass set constrains below the goal is said so: the job refuses before any
motion. The moves between the chosen passes are checked in the virtual cell too: one that
would bring the arm or the laser against the object goes through home.

The candidates are made in scan_candidates, timed in scan_timing, predicted in
tre_prediction, chosen in scan_choice and their transits routed in scan_transits; this module
makes the job's plan of them (`plan_job_scan`) and plans it again for the calibrated arm
(`replan`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from cell import Kinematics, nominal_T_base_table
from registration import transform_points
from scenarios.offline.scan_candidates import (
    POINTS_MARGIN,
    Candidate,
    PlanningCell,
    ScanPlanError,
    candidates,
    predicted_object_points,
)
from scenarios.offline.scan_choice import ChosenPass, choose_passes
from scenarios.offline.scan_passes import ObjectBox, PlannedPass, plan_pass
from scenarios.offline.scan_passes import plan_scan as plan_scan_fixed
from scenarios.offline.scan_timing import pass_seconds, scan_seconds
from scenarios.offline.scan_transits import TransitError, route_transits
from scenarios.offline.settings import Scan, ScanPass
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M
from scenarios.offline.tre_prediction import ErrorModel, information_shares, predict_tre
from scenarios.results.scan_plan_result import PassSummary, ScanPlanSummary

Progress = Callable[[str], None]


@dataclass(frozen=True, eq=False)
class ScanPlan:
    """The plan a job scans with: its mode ("auto" or "fixed"), its passes, the predicted
    cell time of the scan [s], the predicted TRE at each target (K,) [m], the chosen passes
    in order, and the candidates considered (auto)."""

    mode: str
    passes: tuple[PlannedPass, ...]
    predicted_time_s: float
    predicted_tre_m: np.ndarray
    chosen: tuple[ChosenPass, ...]
    candidates: tuple[Candidate, ...] = ()
    speed_m_s: float = 0.1
    #: The points (M_k, 3) each chosen pass is predicted to see, in the model frame.
    seen_model: tuple[np.ndarray, ...] = ()
    #: The scan's own stand-off [m] (that of a pass without one of its own).
    standoff_m: float = 0.28

    @property
    def specs(self) -> tuple[ScanPass, ...]:
        """The chosen passes' parameters, in scan order."""
        return tuple(
            ScanPass(
                tilt_deg=c.tilt_deg, heading_deg=c.heading_deg, offset_m=c.offset_m,
                standoff_m=c.standoff_m,
            )
            for c in self.chosen
        )  # fmt: skip

    def summary(self, scan_time_s: float | None) -> ScanPlanSummary:
        """What results.json keeps of the plan: `scan_time_s` is the cell time the scan took
        [s] (None: it did not run)."""
        return ScanPlanSummary(
            mode=self.mode,
            passes=len(self.passes),
            sweep_speed_m_s=self.speed_m_s,
            scan_time_s=scan_time_s,
            predicted_scan_time_s=self.predicted_time_s,
            predicted_tre_max_m=self.predicted_tre_max_m,
            predicted_tre_m=tuple(float(t) for t in self.predicted_tre_m),
            candidates=len(self.candidates),
            chosen=tuple(
                PassSummary(
                    name=c.name,
                    tilt_deg=c.tilt_deg,
                    heading_deg=c.heading_deg,
                    offset_m=c.offset_m,
                    standoff_m=self.standoff_m if c.standoff_m is None else c.standoff_m,
                    table_position_m=c.table_position_m,
                    predicted_tre_max_m=None
                    if not np.isfinite(c.predicted_tre_max_m)
                    else c.predicted_tre_max_m,
                    seconds=c.seconds,
                    information_share=c.information_share,
                    through_home=bool(p.q_via),
                )
                for c, p in zip(self.chosen, self.passes, strict=True)
            ),
        )

    @property
    def predicted_tre_max_m(self) -> float:
        return float(np.max(self.predicted_tre_m)) if len(self.predicted_tre_m) else 0.0


def plan_job_scan(
    where: PlanningCell,
    section: Scan,
    errors: ErrorModel,
    targets_model: np.ndarray,
    say: Progress | None = None,
    unambiguous: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    target_names: tuple[str, ...] | None = None,
    acceptable_tre_m: float | None = None,
) -> ScanPlan:
    """The job's scan plan in the virtual cell `where`: in mode "auto" chosen among the
    candidates for `targets_model` (K, 3, model frame); in mode "fixed" the configuration's
    passes, with the same prediction. `unambiguous(points_table (N, 3), pass_labels (N,))`:
    whether the match of such a scan finds one pose. Raises ScanPlanError if "auto" leaves a
    target (named by `target_names`) unconstrained, or above the goal and above
    `acceptable_tre_m` [m] (what the match accepts; None: above the goal refuses), or the
    match ambiguous. A plan short of the goal but within `acceptable_tre_m` is scanned, and
    said so."""
    tell = say or (lambda _m: None)
    if section.plan == "fixed":
        return _fixed_plan(where, section, errors, targets_model)
    speed = section.planning.sweep_speed_m_s or min(0.5, errors.voxel_m / section.period_s)
    if errors.voxel_m <= 0 and section.planning.sweep_speed_m_s is None:
        speed = section.speed_m_s
    section = section.model_copy(update={"speed_m_s": speed})
    found_all, tried = candidates(where, section)
    tell(
        f"scan plan: {len(found_all)} of {tried} candidate passes reachable, clear and "
        "seeing the object"
    )

    def is_unique(passes: list[Candidate]) -> bool:
        if unambiguous is None:
            return True
        points = np.concatenate([c.points_model for c in passes])
        labels = np.concatenate([np.full(len(c.points_model), k) for k, c in enumerate(passes)])
        return unambiguous(transform_points(where.T_table_object, points), labels)

    # A picked pass the arm finds no clear way to (routed only once the plan is chosen) is
    # left out of the candidates, and the passes are chosen again without it.
    usable_now = found_all
    while True:
        try:
            return _choose_plan(
                where, section, errors, targets_model, usable_now, tried, tell, is_unique,
                target_names, acceptable_tre_m,
            )  # fmt: skip
        except TransitError as blocked:
            if blocked.plan is None or len(usable_now) <= 1:
                raise
            left_out = blocked.plan[blocked.index]
            tell(f"scan plan: no clear way to {left_out.planned.name}: chosen again without it")
            usable_now = tuple(c for c in usable_now if c is not left_out)


def _choose_plan(
    where: PlanningCell,
    section: Scan,
    errors: ErrorModel,
    targets_model: np.ndarray,
    found_all: tuple[Candidate, ...],
    tried: int,
    tell: Progress,
    is_unique: Callable[[list[Candidate]], bool],
    target_names: tuple[str, ...] | None,
    acceptable_tre_m: float | None,
) -> ScanPlan:
    """plan_job_scan's "auto" plan among the candidates `found_all` (of `tried`)."""
    goal = section.planning.goal_tre_m
    budget, min_gain = section.planning.budget_s, section.planning.min_gain
    needed = POINTS_MARGIN * section.min_points

    def enough(passes: list[Candidate]) -> bool:
        seen = [c.points_model for c in passes]
        return predicted_object_points(seen, section, [c.planned for c in passes]) >= needed

    picked, records, tre, unique = choose_passes(
        found_all, targets_model, errors, goal, budget, tell, is_unique, min_gain, enough
    )
    names = target_names or tuple(f"target {k + 1}" for k in range(len(targets_model)))
    usable = f"{len(found_all)} of {tried} candidate passes reachable, clear and seeing the object"
    if not picked or not np.all(np.isfinite(tre)):
        free = [names[k] for k in np.flatnonzero(~np.isfinite(tre))] if picked else list(names)
        raise ScanPlanError(
            f"scan plan: no reachable pass constrains {', '.join(free)} ({usable}); the job "
            "refuses before any motion"
        )
    if np.max(tre) > goal:
        over_goal = _over_goal(picked, found_all, tre, names, usable, section)
        if acceptable_tre_m is None or np.max(tre) > acceptable_tre_m:
            limit = (
                ""
                if acceptable_tre_m is None
                else f" and above the {acceptable_tre_m * 1e3:.3f} mm the match accepts "
                "(localization.registration.max_predicted_tre_m)"
            )
            raise ScanPlanError(f"scan plan: {over_goal}{limit}; the job refuses before any motion")
        tell(
            f"warning: scan plan: {over_goal}; the job scans the {len(picked)} passes that "
            f"get there (the match accepts up to {acceptable_tre_m * 1e3:.3f} mm)"
        )
    if picked and not enough(picked):
        raise ScanPlanError(_few_points(picked, section, tre, goal))
    if not unique:
        raise ScanPlanError(
            f"scan plan: the match of what the {len(picked)} picked passes would see is "
            f"still ambiguous within the {section.planning.budget_s:g} s budget (a rival "
            "pose or a symmetry fits as well); the job refuses before any motion"
        )
    try:
        return _auto_plan(where, section, picked, records, tre, found_all)
    except TransitError as blocked:
        blocked.plan = tuple(picked)
        raise


def _fixed_plan(
    where: PlanningCell, section: Scan, errors: ErrorModel, targets_model: np.ndarray
) -> ScanPlan:
    """The configuration's passes (scan.plan "fixed") routed in the virtual cell, with the
    predicted TRE at `targets_model` (K, 3, model frame) of the plan and of each pass
    added in turn, and each pass' share of the information."""
    kin, q_home, T_base_table = where.kin, where.q_home, where.T_base_table
    raster = where.raster(section)
    passes = route_transits(
        where.cell, kin,
        plan_scan_fixed(kin, where.box, section, q_home, T_base_table, None, raster),
        q_home, T_base_table,
    )  # fmt: skip
    found = []
    for spec, planned in zip(section.passes, passes, strict=True):
        p, n = where.predict(planned)
        found.append(Candidate(spec, planned, p, n, pass_seconds(planned, section)))
    tre, _ = predict_tre(found, targets_model, errors)
    shares = information_shares(found, targets_model, errors)
    so_far = [float(np.max(predict_tre(found[: k + 1], targets_model, errors)[0]))
              for k in range(len(found))]  # fmt: skip
    chosen = tuple(
        ChosenPass(
            c.planned.name, c.spec.tilt_deg, c.spec.heading_deg, c.spec.offset_m,
            c.spec.standoff_m, c.planned.table_position_m, worst, c.seconds, share,
        )
        for c, share, worst in zip(found, shares, so_far, strict=True)
    )  # fmt: skip
    seconds = scan_seconds(passes, section, q_home, where.joint_speed)
    return ScanPlan(
        "fixed", passes, seconds, tre, chosen, (), section.speed_m_s,
        tuple(c.points_model for c in found), section.standoff_m,
    )  # fmt: skip


def _over_goal(
    picked: list[Candidate],
    found_all: tuple[Candidate, ...],
    tre: np.ndarray,
    names: tuple[str, ...],
    usable: str,
    section: Scan,
) -> str:
    """What a plan whose predicted TRE (K,) [m] is above the goal at the targets `names`
    says of it: which targets, by how much, and why the choice stopped there (every
    `usable` pass picked, the budget spent, or no pass left gains enough)."""
    goal, budget = section.planning.goal_tre_m, section.planning.budget_s
    over = [f"{names[k]} {tre[k] * 1e3:.3f} mm" for k in np.flatnonzero(tre > goal)]
    spent = sum(c.seconds for c in picked)
    rest = [c.seconds for c in found_all if c not in picked]
    if not rest:
        why = f"every usable pass is in the plan ({usable})"
    elif spent + min(rest) > budget:
        why = f"the {budget:g} s budget is spent"
    else:
        why = f"no further pass lowers it by {section.planning.min_gain:.0%}"
    return (
        f"{', '.join(over)} predicted above the goal {goal * 1e3:.3f} mm "
        f"(localization.scan.planning.goal_tre_m): {why}"
    )


def _auto_plan(
    where: PlanningCell,
    section: Scan,
    picked: list[Candidate],
    records: list[ChosenPass],
    tre: np.ndarray,
    found_all: tuple[Candidate, ...],
) -> ScanPlan:
    """The plan of the `picked` passes (their records, the plan's predicted TRE (K,) [m],
    every candidate considered), re-planned in scan order (alternating sweeps join without
    crossing) and routed in the virtual cell."""
    kin, q_home, T_base_table = where.kin, where.q_home, where.T_base_table
    specs = tuple(c.spec for c in picked)
    raster = where.raster(section)
    passes = route_transits(
        where.cell, kin,
        plan_scan_fixed(kin, where.box, section, q_home, T_base_table, specs, raster),
        q_home, T_base_table,
    )  # fmt: skip
    return ScanPlan(
        "auto",
        passes,
        scan_seconds(passes, section, q_home, where.joint_speed),
        tre,
        tuple(records),
        found_all,
        section.speed_m_s,
        tuple(c.points_model for c in picked),
        section.standoff_m,
    )


def replan(
    kin: Kinematics,
    box: ObjectBox,
    section: Scan,
    plan: ScanPlan,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
) -> tuple[PlannedPass, ...]:
    """The plan's passes for the arm and table the cell now believes (`kin`, `table`: the
    calibrated ones): each pass from its planned joints, at its planned table position
    first, through the same via points."""
    out = []
    for k, (spec, planned) in enumerate(zip(plan.specs, plan.passes, strict=True)):
        s = planned.table_position_m
        order = (s, *(p for p in TABLE_CANDIDATES_M if p != s))
        raster = section.raster if planned.raster_m else None
        again = plan_pass(kin, box, section, spec, k, planned.q_start, table, order, raster)
        out.append(replace(again, q_via=planned.q_via))
    return tuple(out)


def _few_points(picked: list[Candidate], section: Scan, tre: np.ndarray, goal_m: float) -> str:
    """Why a plan whose passes see too few of the object's points refuses, and the change
    that would let it run: the lower `min_points` its predicted TRE already meets the goal
    with, or a longer budget."""
    seen = predicted_object_points(
        [c.points_model for c in picked], section, [c.planned for c in picked]
    )
    change = (
        f"set localization.scan.min_points={_round_down(seen / POINTS_MARGIN)} (this plan's "
        f"predicted TRE, {np.max(tre) * 1e3:.3f} mm, meets the {goal_m * 1e3:.3f} mm goal with "
        "those points)"
        if np.max(tre) <= goal_m
        else "allow a longer scan (localization.scan.planning.budget_s)"
    )
    return (
        f"scan plan: the {len(picked)} passes that fit the "
        f"{section.planning.budget_s:g} s budget see about {seen} of the object's points, "
        f"fewer than the {POINTS_MARGIN:g} x {section.min_points} the match requires "
        f"(localization.scan.min_points, with the prediction's margin); {change}; the job "
        "refuses before any motion"
    )


def _round_down(value: float) -> int:
    """`value` rounded down to two significant digits (at least 100: min_points' floor)."""
    magnitude = 10 ** max(2, int(np.floor(np.log10(max(value, 1.0)))) - 1)
    return max(100, int(value // magnitude * magnitude))
