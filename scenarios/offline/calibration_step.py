"""The kinematic calibration as a step of a job (skull, assembly): the reference spheres in
the real cell, the view plan from the run's `calibration:` section, the calibration itself
(scenarios.offline.calibration) handing the calibrated arm to the controller, and the figures the
run reports, with the evaluator's measure of the arm against the truth.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell import Controller
from scenarios.offline.calibration import CalibrationResult, calibrate
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT, CalibrationError
from scenarios.offline.calibration_identification import CalibrationPriors
from scenarios.offline.calibration_measurement import CalibrationPlan, Clear
from scenarios.offline.laser_latency import LatencyPlan
from scenarios.offline.scan_passes import ObjectBox
from scenarios.offline.settings import Calibration

Progress = Callable[[str], None]


def calibration_priors(section: Calibration) -> CalibrationPriors:
    """The calibration's data-sheet priors and groups from the run's calibration section."""
    return CalibrationPriors(**section.priors.model_dump(), groups=tuple(section.identify))


def calibration_plan(section: Calibration, seed: int) -> CalibrationPlan:
    """The calibration's view plan from the run's calibration section."""
    return CalibrationPlan(
        table_positions_m=tuple(section.table_positions_m),
        views_per_sphere=section.views_per_sphere,
        lines_per_view=section.lines_per_view,
        standoff_m=section.standoff_m,
        max_tilt_rad=float(np.deg2rad(section.max_tilt_deg)),
        seed=seed,
    )


def check_artifact_clearance(box: ObjectBox, crop_margin_m: float) -> None:
    """The calibration spheres must stand outside the region the scan keeps as the object
    (its nominal footprint enlarged by `crop_margin_m` [m]); raises CalibrationError."""
    c = DEFAULT_ARTIFACT.centres_table
    reach = box.radius_xy + crop_margin_m + DEFAULT_ARTIFACT.radius_m
    gap = np.linalg.norm(c[:, :2] - box.centre[:2], axis=1) - reach
    if np.any(gap < 0.0):
        raise CalibrationError(
            f"the object's footprint (radius {box.radius_xy * 1e3:.0f} mm about its centre, "
            f"plus {crop_margin_m * 1e3:.0f} mm of crop margin) reaches the calibration "
            f"spheres at {np.round(c[:, :2] * 1e3).tolist()} mm on the table; use a smaller "
            "object or set calibration.enabled: false"
        )


def calibrate_arm(
    controller: Controller,
    section: Calibration,
    seed: int,
    say: Progress,
    on_view: Callable[[], None] | None = None,
    clear: Clear | None = None,
    laser_period_s: float = LatencyPlan.period_s,
) -> CalibrationResult:
    """Calibrate the arm on the reference spheres (the views `clear` of the object) and give
    the controller the calibrated kinematics (the scan, the IK and the program use it from
    then on); the laser's latency, where it is identified, from sweeps read at the laser's
    period `laser_period_s` [s]."""
    say("calibration: the laser views the reference spheres")
    calibration = calibrate(
        controller,
        DEFAULT_ARTIFACT,
        calibration_plan(section, seed),
        section.max_residual_rms_m,
        on_view=on_view,
        priors=calibration_priors(section),
        clear=clear,
        latency=LatencyPlan(period_s=laser_period_s) if section.latency == "identify" else None,
    )
    controller.set_absolute_accuracy(calibration.kinematics)
    if (latency := calibration.latency) is not None:
        controller.set_laser_latency(latency.latency_s)
        say(
            f"calibration: the laser's latency {latency.latency_s * 1e3:.2f} "
            f"+- {latency.sigma_s * 1e3:.2f} ms ({latency.lines} lines in {latency.sweeps} "
            f"sweeps, residual rms {latency.residual_rms_m * 1e3:.3f} mm)"
        )
    say(
        f"calibration: {calibration.points} points in {calibration.views} views, residual "
        f"rms {calibration.residual_rms_before_m * 1e3:.3f} mm (nominal arm) -> "
        f"{calibration.residual_rms_after_m * 1e3:.3f} mm, {calibration.seconds:.1f} s"
    )
    return calibration
