"""The real cell of a job: the object's real entity placed at its true pose on the table
(fixed, or loose for a part the gripper picks), the calibration spheres when the job
calibrates, the cell's error sources from the run's noise section, the evaluator (the only
reader of the truth) and the recording hooks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cell import Controller, FixedMesh, FixedPrimitive, LooseMesh
from cell.irb2400_arm import irb2400
from cell.robot_arm import Robot
from cell.sim import (
    ArmErrors,
    CellConfig,
    DriveErrors,
    EncoderNoise,
    TableErrors,
    ToolErrors,
    make_cell,
)
from cell.sim.faults import Fault
from models.model import ObjectModel
from models.model_error import ModelErrorSpec
from models.robot import RACK_POS
from scenarios.configuration.cell_sections import Noise
from scenarios.configuration.job_config import JobConfig
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.calibration_step import check_artifact_clearance
from scenarios.offline.laser_sheet import LaserSection
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.scan_passes import ObjectBox
from scenarios.realcell.cell_log import CellLog
from scenarios.realcell.evaluation import Evaluator
from scenarios.realcell.real_placement import draw_true_pose
from scenarios.results.evaluations import TouchMeasure


@dataclass(frozen=True, eq=False)
class JobCell:
    """A job's real cell: the controller (what the program sees), the evaluator (the
    truth; None for a controller across the network, whose truth, if any, is on the other
    side), what measures the touches (the evaluator, or the twin across the network), the
    recording hooks, the object's nominal pose T_table_object (4, 4) and its nominal
    footprint for the scan."""

    controller: Controller
    evaluator: Evaluator | None
    log: CellLog
    T_table_nominal: np.ndarray
    box: ObjectBox
    touches: TouchMeasure


def model_error(noise: Noise) -> ModelErrorSpec:
    """The model error of the real entity, from the run's noise section."""
    return ModelErrorSpec(
        deformation_rms=noise.model_deformation_rms_m, noise_rms=noise.model_noise_rms_m
    )


def cell_config(
    noise: Noise,
    seed: int,
    fixtures: tuple[FixedMesh | FixedPrimitive, ...],
    robot: Robot | None = None,
    rack_xyz: tuple[float, float, float] = RACK_POS,
    faults: tuple[Fault, ...] = (),
    laser: LaserSection | None = None,
) -> CellConfig:
    """The real cell's configuration from the run's noise section, with its `robot` (default
    the built-in arm), the tool rack at `rack_xyz` [m] and its `laser`."""
    return CellConfig(
        seed=seed,
        noise_draw=noise.draw,
        robot=robot or irb2400(),
        rack_xyz=rack_xyz,
        arm=ArmErrors(
            noise.arm_length_sigma_m, noise.arm_offset_sigma_rad, noise.arm_thermal_strain
        ),
        drives=DriveErrors(**noise.drives.model_dump()),
        tools=ToolErrors(**noise.tools.model_dump()),
        encoder=EncoderNoise(noise.encoder_sigma_rad),
        table=TableErrors(
            noise.table_bias_sigma_m,
            noise.table_repeat_sigma_m,
            noise.table_straightness_sigma_m,
            noise.table_pitch_sigma_rad,
            noise.table_yaw_sigma_rad,
        ),
        laser=(laser or LaserSection()).data_sheet(noise.laser_sigma_m),
        fixtures=fixtures,
        faults=faults,
    )


def artifact_fixtures(seed: int) -> tuple[FixedPrimitive, ...]:
    """The calibration spheres as they really stand: their design centres moved by a seeded
    1 mm (per axis) that the calibration does not know."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7]))
    centres = DEFAULT_ARTIFACT.centres_table
    return DEFAULT_ARTIFACT.fixtures(centres + rng.normal(0.0, 1e-3, centres.shape))


def build_job_cell(
    config: JobConfig,
    virtual: ObjectModel,
    real: ObjectModel,
    robot: Robot,
    recording: Any | None = None,
    faults: tuple[Fault, ...] = (),
) -> JobCell:
    """The job's real cell: the real entity placed at a true pose drawn around the nominal
    one from the job's seed (its own random stream: fixed or loose on the table), the
    calibration spheres if the job calibrates (they must stand clear of the object's
    footprint plus the scan's crop margin), the job's arm and rack, the cell's errors and
    `faults`; the recording started (cell geometry, the virtual model at its nominal pose,
    the bodies)."""
    obj = config.cell.object
    placement, name, seed = obj.placement, config.object_name, config.seed
    loose = obj.fixing == "loose"
    stream = 6 if loose else 5  # the true placement's random stream
    rgba = (0.7, 0.72, 0.78, 1.0) if loose else (0.9, 0.85, 0.75, 1.0)
    crop_margin_m = config.localization.scan.crop_margin_m
    noise, rack_xyz, laser = config.cell.noise, config.cell.rack_xyz, config.cell.laser
    draw = [obj.draw] if obj.draw else []  # 0: the seed's own placement, as it always was
    rng = np.random.default_rng(np.random.SeedSequence([seed, stream, *draw]))
    T_table_nominal = nominal_pose(placement, virtual.mesh.vertices)
    T_table_true = draw_true_pose(placement, real.mesh.vertices, rng)
    pieces = tuple(p.vertices for p in real.convex_pieces)
    mesh = real.mesh
    box = ObjectBox.of(virtual.mesh.vertices, T_table_nominal)
    spheres: tuple[FixedPrimitive, ...] = ()
    if config.calibration.enabled:
        check_artifact_clearance(box, crop_margin_m)
        spheres = artifact_fixtures(seed)
    if loose:
        part = LooseMesh(
            name, mesh.vertices, mesh.faces, T_table_true, convex_pieces=pieces, rgba=rgba
        )
        real_cell = replace(
            cell_config(noise, seed, spheres, robot, rack_xyz, faults, laser), parts=(part,)
        )
    else:
        fixed = FixedMesh(
            name, mesh.vertices, mesh.faces, T_table_true, convex_pieces=pieces, rgba=rgba
        )
        real_cell = cell_config(noise, seed, (fixed, *spheres), robot, rack_xyz, faults, laser)
    controller, truth = make_cell(replace(real_cell, clock_start_utc=config.cell.clock_utc))
    evaluator = Evaluator(truth, real, name)
    log = CellLog(recording, controller, evaluator, name, virtual.name)
    if recording is not None:
        recording.log_model(virtual, T_table_nominal)
    return JobCell(controller, evaluator, log, T_table_nominal, box, evaluator)
