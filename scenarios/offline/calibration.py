"""In-cell calibration: the laser views reference spheres on the table at several table
positions, and the cell's model (scenarios.offline.cell_model) is identified: the arm's
kinematic parameters, the compliance of its joints 2 and 3, the laser's mounting and range
scale, and the table axis' deviation from a straight travel.

What industrial cells do (absolute-accuracy calibration, sphere-artifact self-calibration),
with the sliding table in the loop: three spheres on posts stand at one end of the table; at
each of a few table positions the laser looks at each sphere from many arm configurations
(tilts, headings, turns of the laser about its axis, near and far), a few static laser lines
per view. Every laser point is rebuilt from the measured joints (the motors' angles), its
range and ray and a candidate cell model: the links sag from the motors by the gravity torque
(data-sheet inertias, the laser's nominal mass) times the compliance; the laser's optical
frame sits on its tool plate by a candidate mounting; its ranges carry a candidate scale. The
spheres' centres are unknowns in the table frame, and the table frame at each position is the
nominal straight travel moved by the table model's deviation there: seeing the same spheres at
several positions is what tells the table's pitch, yaw and bow from the arm's own errors (a
joint calibration of the arm and its 7th axis). Each point's residual is its distance from its
sphere's centre minus the sphere's certified radius. Gauss-Newton with priors from the data
sheets (`CalibrationPriors`) identifies the model jointly with the centres.

The laser's mounting on the flange is part of the model: the tool changer locks a tool where
the flange meets it, so a tool fetched with an inaccurate arm sits off its nominal mounting by
the arm's error at the rack. With the tool sitting in its slot when it is fetched, the laser in
the base frame is FK(q) FK(q_lock)^-1 T_base_slot T_tool_laser, for any candidate arm. The
flange's own parameters cancel from that product, and every tool is fetched the same way.

What the model leaves out (lost motion, pose repeatability, the other tools' TCPs, the laser's
noise) stays in the residual, which the result reports.

After the measurement the laser goes back to its slot with the kinematics that fetched it, so
that it sits where it sat; the next fetch, with the calibrated arm, mounts it closely.

The artifact is in scenarios.offline.calibration_artifact, the measurement in
calibration_measurement, the identification in calibration_identification; this module runs
them in turn (`calibrate`) and holds what the calibration hands on (`CalibrationResult`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller, Kinematics
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT, SphereArtifact
from scenarios.offline.calibration_identification import (
    CalibrationPriors,
    FittedPoints,
    ParameterLayout,
    cell_model,
    identify,
)
from scenarios.offline.calibration_measurement import (
    CalibrationPlan,
    Clear,
    Progress,
    measure_spheres,
)
from scenarios.offline.cell_model import CellModel
from scenarios.offline.laser_latency import (
    LatencyEstimate,
    LatencyPlan,
    identify_latency,
    sweep_artifact,
)
from scenarios.results.calibration_check_result import DriftCheck
from scenarios.results.evaluations import CalibrationSummary


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The identified cell.

    Attributes:
        model: the cell's model (scenarios.offline.cell_model) for the scan, the program and
            the export; kinematics: its arm (motor angles in).
        links: the arm's rigid kinematics with the identified deviations (for a URDF).
        parameters: the names of the arm's deviations (cell.robots); deviations: (P,).
        stiffness_nm_rad: (2,) joints 2 and 3 [N m/rad] (inf: not modelled).
        laser_mount: (6,) the laser's optical frame off its drawing: translation [m] and
            rotation vector [rad], in its tool frame; laser_scale: its range scale error.
        table_coefficients: (6, 2) the table model's terms (cell_model.TableModel).
        centres_table: (S, 3) estimated sphere centres in the table frame [m].
        residual_rms_before_m: point residual RMS with the data sheet's cell (centres
            fitted) [m]; residual_rms_after_m: with the identified model: what it leaves out.
        points, views, table_positions: inlier points, arm configurations, table positions
            used; iterations of the fit; groups identified; seconds: wall time [s].
        fitted: every point as the identified model places it (for a picture of the fit).
        latency: the laser's latency identified on a sphere (None: not identified, its
            lines come with the encoders of their instant).
        given: the saved calibration (its file) the job started from, and `check`: its quick
            check (scenarios.offline.calibration_check), where it was given.
    """

    model: CellModel
    links: Kinematics
    parameters: tuple[str, ...]
    deviations: np.ndarray
    stiffness_nm_rad: np.ndarray
    laser_mount: np.ndarray
    laser_scale: float
    table_coefficients: np.ndarray
    centres_table: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    views: int
    table_positions: int
    iterations: int
    groups: tuple[str, ...]
    seconds: float
    fitted: FittedPoints | None = None
    latency: LatencyEstimate | None = None
    given: str | None = None
    check: DriftCheck | None = None

    @property
    def kinematics(self) -> Kinematics:
        return self.model.kinematics

    def summary(self) -> CalibrationSummary:
        """The figures results.json keeps (SI units)."""
        return CalibrationSummary(
            residual_rms_before_m=self.residual_rms_before_m,
            residual_rms_after_m=self.residual_rms_after_m,
            seconds=self.seconds,
            points=self.points,
            views=self.views,
            table_positions=self.table_positions,
            iterations=self.iterations,
            groups=tuple(self.groups),
            deviations={n: float(v) for n, v in zip(self.parameters, self.deviations, strict=True)},
            stiffness_nm_rad=tuple(float(v) for v in self.stiffness_nm_rad),
            laser_mount_m=tuple(float(v) for v in self.laser_mount[:3]),
            laser_mount_rad=tuple(float(v) for v in self.laser_mount[3:]),
            laser_scale=float(self.laser_scale),
            table_coefficients=tuple(
                tuple(float(v) for v in row) for row in self.table_coefficients
            ),
            laser_latency_s=None if self.latency is None else self.latency.latency_s,
            laser_latency_sigma_s=None if self.latency is None else self.latency.sigma_s,
            given=self.given,
            check=self.check,
        )


def calibrate(
    controller: Controller,
    artifact: SphereArtifact = DEFAULT_ARTIFACT,
    plan: CalibrationPlan | None = None,
    max_residual_rms_m: float = 1e-4,
    progress: Progress | None = None,
    on_view: Callable[[], None] | None = None,
    priors: CalibrationPriors | None = None,
    clear: Clear | None = None,
    latency: LatencyPlan | None = None,
) -> CalibrationResult:
    """Measure the artifact (the views `clear` of the object) and identify the cell (see
    the module's docstring); with a `latency` plan and a controller that pairs the laser's
    lines by time, sweep a sphere before the laser goes back and identify its latency
    (scenarios.offline.laser_latency). The controller is left as it was: the caller decides
    to use the result."""
    t0 = time.perf_counter()
    plan = plan or CalibrationPlan()
    priors = priors or CalibrationPriors()
    paired_s = controller.laser_latency_s if latency is not None else None
    m = measure_spheres(controller, artifact, plan, progress, on_view, clear, paired_s is None)
    sweeps = None
    if latency is not None and paired_s is not None:
        sweeps = sweep_artifact(controller, artifact, latency, clear)
        controller.move_joints(controller.q_home)
        controller.return_tool()
    robot = controller.robot
    fit = identify(m, robot, priors, max_residual_rms_m=max_residual_rms_m)
    layout = ParameterLayout.of(robot, priors, m.stations)
    dev, compliance, mount, scale, table = layout.unpack(fit.theta)
    stiffness = np.where(compliance > 0.0, 1.0 / np.where(compliance > 0, compliance, 1.0), np.inf)
    model = cell_model(robot, fit, priors)
    estimate = None
    if sweeps is not None and paired_s is not None:
        directions = controller.laser_directions_tcp
        estimate = identify_latency(sweeps, model, directions, artifact.radius_m, paired_s)
    return CalibrationResult(
        model,
        robot.kinematics(dev),
        robot.parameters,
        dev,
        stiffness,
        mount,
        scale,
        table,
        fit.centres_table,
        fit.residual_rms_before_m,
        fit.residual_rms_after_m,
        fit.points,
        m.views,
        len(plan.table_positions_m),
        fit.iterations,
        tuple(priors.groups),
        time.perf_counter() - t0,
        fit.fitted,
        estimate,
    )
