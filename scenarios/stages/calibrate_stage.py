"""The calibration: the arm, the laser's mounting and range scale and the table identified
on the calibration spheres (scenarios.offline.calibration), the views kept clear of the
object by the fixture's tolerance."""

from __future__ import annotations

from dataclasses import dataclass, replace

from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.calibration_step import calibrate_arm
from scenarios.offline.job_cell import clear_of, job_virtual_cell, placement_uncertainty_m
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState


def calibrate_stage(ctx: StageContext) -> CalibrationResult:
    """Calibrate the arm on the spheres; every view keeps the object's footprint plus the
    fixture's tolerance clear (the virtual cell, the object at its nominal pose)."""
    settings, controller = ctx.settings, ctx.controller
    name = settings.object_name
    cell = job_virtual_cell(
        controller.robot, settings.rack_xyz, ctx.virtual, ctx.T_table_nominal, True, name
    )
    margin = placement_uncertainty_m(
        settings.tolerance, settings.placement.lift_m, ctx.box.radius_xy
    )
    return calibrate_arm(
        controller,
        settings.calibration,
        settings.seed,
        ctx.hooks.say,
        lambda: ctx.hooks.moved("view"),
        clear_of(cell, "laser", name, margin),
        settings.localization.scan.period_s,
    )


@dataclass(frozen=True)
class Calibrated(Outcome):
    """The calibration; from here on the stages believe its cell model."""

    calibration: CalibrationResult

    def advance(self, state: JobState) -> JobState:
        return replace(state, calibration=self.calibration, model=self.calibration.model)


@dataclass(frozen=True)
class Calibrate:
    """The stage "calibrate": every later stage uses the calibrated arm."""

    name: str = "calibrate"
    title: str = "the arm, the laser and the table, on the spheres"

    def due(self, ctx: StageContext) -> bool:
        return True

    def run(self, ctx: StageContext) -> Calibrated:
        return Calibrated(calibrate_stage(ctx))
