"""The kinematic calibration as a step of a job (skull, assembly): the reference spheres in
the real cell, the view plan from the run's `calibration:` section, the calibration itself
(scenarios.offline.calibration) handing the calibrated arm to the controller, and the figures the
run reports, with the evaluator's measure of the arm against the truth.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from cell import Controller, FixedPrimitive, Kinematics
from scenarios.jobs.config import Calibration
from scenarios.offline.calibration import (
    DEFAULT_ARTIFACT,
    CalibrationError,
    CalibrationPlan,
    CalibrationResult,
    calibrate,
)
from scenarios.offline.scan import ObjectBox
from scenarios.realcell.evaluation import Evaluator

Progress = Callable[[str], None]


def calibration_plan(section: Calibration, seed: int) -> CalibrationPlan:
    """The calibration's view plan from the run's calibration section."""
    return CalibrationPlan(
        table_position_m=section.table_position_m,
        views_per_sphere=section.views_per_sphere,
        lines_per_view=section.lines_per_view,
        standoff_m=section.standoff_m,
        max_tilt_rad=float(np.deg2rad(section.max_tilt_deg)),
        seed=seed,
    )


def artifact_fixtures(seed: int) -> tuple[FixedPrimitive, ...]:
    """The calibration spheres as they really stand: their design centres moved by a seeded
    1 mm (per axis) that the calibration does not know."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7]))
    centres = DEFAULT_ARTIFACT.centres_table
    return DEFAULT_ARTIFACT.fixtures(centres + rng.normal(0.0, 1e-3, centres.shape))


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
) -> CalibrationResult:
    """Calibrate the arm on the reference spheres and give the controller the calibrated
    kinematics (the scan, the IK and the program use it from then on)."""
    say("calibration: the laser views the reference spheres")
    calibration = calibrate(
        controller,
        DEFAULT_ARTIFACT,
        calibration_plan(section, seed),
        section.max_residual_rms_m,
        on_view=on_view,
    )
    controller.kinematics = calibration.kinematics
    say(
        f"calibration: {calibration.points} points in {calibration.views} views, residual "
        f"rms {calibration.residual_rms_before_m * 1e3:.3f} mm (nominal arm) -> "
        f"{calibration.residual_rms_after_m * 1e3:.3f} mm, {calibration.seconds:.1f} s"
    )
    return calibration


def calibration_results(
    evaluator: Evaluator,
    nominal: Kinematics,
    calibration: CalibrationResult | None,
    q_job: np.ndarray,
    tool: str,
) -> dict[str, Any]:
    """The calibration's figures and, from the truth, the TCP error of `tool` on the nominal
    and the calibrated arm at the job's configurations `q_job` (K, 6)."""
    out: dict[str, Any] = {"enabled": calibration is not None}
    models = {"nominal": nominal}
    if calibration is not None:
        out.update(calibration.summary())
        models["calibrated"] = calibration.kinematics
    for label, kin in models.items():
        e = evaluator.kinematics_error(kin, q_job, tool)
        out[f"tcp_error_{label}_mean_m"] = e.mean_m
        out[f"tcp_error_{label}_max_m"] = e.max_m
    out["tcp_error_configurations"] = len(q_job)
    return out
