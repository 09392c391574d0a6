"""The calibration: the arm, the laser's mounting and range scale and the table identified
on the calibration spheres (scenarios.offline.calibration), the views kept clear of the
object by the fixture's tolerance; or the calibration an earlier run on the same cell saved
(scenarios.offline.saved_calibration), kept where its quick check finds the cell where it
was (scenarios.offline.calibration_check) and made anew where not. Either way the run keeps
the calibration it used in its folder (calibration.json)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.calibration_check import Clear, check_drift
from scenarios.offline.calibration_measurement import CalibrationPlan
from scenarios.offline.calibration_step import calibrate_arm
from scenarios.offline.commissioning import cell_label
from scenarios.offline.job_cell import clear_of, job_virtual_cell, placement_uncertainty_m
from scenarios.offline.saved_calibration import (
    CALIBRATION_FILE,
    SavedCalibration,
    read_calibration,
    rebuilt,
    saved,
    to_json,
)
from scenarios.outputs.run_folder import write_json
from scenarios.scenario_errors import ScenarioError
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState


def calibrate_stage(ctx: StageContext) -> CalibrationResult:
    """Calibrate the arm on the spheres; every view keeps the object's footprint plus the
    fixture's tolerance clear (the virtual cell, the object at its nominal pose)."""
    settings = ctx.settings
    return calibrate_arm(
        ctx.controller,
        settings.calibration,
        settings.seed,
        ctx.hooks.say,
        lambda: ctx.hooks.moved("view"),
        _clear(ctx),
        settings.localization.scan.period_s,
    )


def cell_name(ctx: StageContext) -> str:
    """The cell as its saved calibration names it (scenarios.offline.commissioning)."""
    return cell_label(ctx.controller.robot.name, ctx.settings.seed)


#: The drift a kept calibration may have, as a share of the job's RMS goal: added in
#: quadrature to an error at the goal, 30 % of it makes it 4.4 % larger.
DRIFT_SHARE = 0.3


def _clear(ctx: StageContext) -> Clear:
    """Whether a laser view keeps the object's footprint plus the fixture's tolerance clear
    (the virtual cell, the object at its nominal pose)."""
    settings, controller = ctx.settings, ctx.controller
    name = settings.object_name
    cell = job_virtual_cell(
        controller.robot, settings.rack_xyz, ctx.virtual, ctx.T_table_nominal, True, name
    )
    margin = placement_uncertainty_m(
        settings.tolerance, settings.placement.lift_m, ctx.box.radius_xy
    )
    return clear_of(cell, "laser", name, margin)


def checked(ctx: StageContext, result: CalibrationResult) -> CalibrationResult:
    """`result` (a saved calibration) with its quick check on the cell now
    (scenarios.offline.calibration_check: the spheres from `calibration.check_views` views
    each at the middle table position); where it fails, the cell calibrated anew."""
    section = ctx.settings.calibration
    positions = section.table_positions_m
    plan = CalibrationPlan(
        (positions[len(positions) // 2],), section.check_views, section.lines_per_view,
        section.standoff_m, float(np.deg2rad(section.max_tilt_deg)), ctx.settings.seed + 7,
    )  # fmt: skip
    tolerance = section.check_tolerance_m
    if tolerance is None:
        goal = ctx.settings.goal_rms_m
        tolerance = DRIFT_SHARE * goal if goal is not None else 1.0e-4
    check = check_drift(ctx.controller, result, DEFAULT_ARTIFACT, plan, tolerance, _clear(ctx))
    verdict = "the calibration holds" if check.passed else "calibrating anew"
    if check.drift_m is None or check.sigma_m is None or check.bound_m is None:
        seen = f"{len(check.shifts_m)} of the spheres seen from enough views: it cannot tell"
    else:
        seen = (
            f"the spheres moved {check.drift_m * 1e3:.3f} +- {check.sigma_m * 1e3:.3f} mm "
            f"since (95 % bound {check.bound_m * 1e3:.3f} mm, tolerance "
            f"{check.tolerance_m * 1e3:.3f} mm)"
        )
    ctx.hooks.say(f"calibration check: {seen}: {verdict}")
    if not check.passed:
        ctx.controller.set_absolute_accuracy(None)
        result = calibrate_stage(ctx)
    return replace(result, check=check)


def given_calibration(ctx: StageContext, path: Path) -> tuple[CalibrationResult, SavedCalibration]:
    """The calibration an earlier run on this cell saved in `path` (checked: its cell, its
    arm, its age), given to the controller as `calibrate_stage` gives its own: the
    calibrated arm, and the laser's latency where the controller pairs lines by time."""
    controller, settings = ctx.controller, ctx.settings
    now = ctx.controller.clock_utc()
    kept = read_calibration(
        path, cell_name(ctx), controller.robot, settings.calibration.max_age_h, now
    )
    result = rebuilt(kept, controller.robot)
    controller.set_absolute_accuracy(result.kinematics)
    if controller.laser_latency_s is not None:
        if result.latency is not None:
            controller.set_laser_latency(result.latency.latency_s)
        elif settings.calibration.latency == "identify":
            raise ScenarioError(
                f"--calibration {path} has no laser latency (the laser it was made with "
                "paired its lines with the encoders of their instant): give the sensor's "
                "calibration.latency [s], or leave --calibration out to identify it now"
            )
    ctx.hooks.say(
        f"calibration: from {path} (made {kept.age_s(now) / 3600.0:.1f} h ago on "
        f"{kept.cell}; residual rms {kept.summary.residual_rms_after_m * 1e3:.3f} mm)"
    )
    return result, kept


@dataclass(frozen=True)
class Calibrated(Outcome):
    """The calibration; from here on the stages believe its cell model."""

    calibration: CalibrationResult

    def advance(self, state: JobState) -> JobState:
        return replace(state, calibration=self.calibration, model=self.calibration.model)


@dataclass(frozen=True)
class Calibrate:
    """The stage "calibrate": every later stage uses the calibrated arm; `given`: the
    calibration an earlier run on the cell saved (`twincell run --calibration FILE`)."""

    given: Path | None = None
    name: str = "calibrate"
    title: str = "the arm, the laser and the table, on the spheres"

    def due(self, ctx: StageContext) -> bool:
        return True

    def run(self, ctx: StageContext) -> Calibrated:
        """Calibrate (or take the calibration `given`), and keep it in the run's folder
        (calibration.json) for later jobs on the same cell."""
        if self.given is None:
            result = calibrate_stage(ctx)
            kept = saved(result, cell_name(ctx), ctx.controller.clock_utc())
        else:
            result, kept = given_calibration(ctx, self.given)
            if ctx.settings.calibration.given == "keep":
                ctx.hooks.say("calibration check: none (calibration.given: keep)")
            else:
                result = checked(ctx, result)
            result = replace(result, given=str(self.given))
            if result.check is not None and not result.check.passed:
                kept = saved(result, cell_name(ctx), ctx.controller.clock_utc())
        write_json(ctx.folder / CALIBRATION_FILE, to_json(kept))
        return Calibrated(result)
