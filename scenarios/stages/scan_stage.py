"""The scan: its passes planned in the virtual cell (chosen for the targets, or the fixed
ones predicted), run on the real cell, the points kept within the object's footprint."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from cell.robot_arm import Robot
from models.model import ObjectModel
from registration import MeshModel, transform_points
from scenarios.offline.cell_model import CellModel
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.localization import localize, scan_passes
from scenarios.offline.scan_candidates import PlanningCell
from scenarios.offline.scan_passes import (
    ObjectBox,
    crop_to_object,
    execute_scan,
    plan_scan,
    raster_for,
)
from scenarios.offline.scan_plan import ScanPlan, plan_job_scan, replan
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.tre_prediction import error_model
from scenarios.stages.context import StageContext
from scenarios.stages.register_stage import acceptance
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState, ScanStage

Progress = Callable[[str], None]


def scan_stage(
    ctx: StageContext,
    model: CellModel,
    scan_plan: ScanPlan | None = None,
) -> ScanStage:
    """Plan the laser passes in the virtual cell, run them on the real one (the points
    rebuilt with the cell's `model`; a pass that lost a stretch run again, the hooks told),
    keep the points within the object's nominal footprint."""
    controller, box, say = ctx.controller, ctx.box, ctx.hooks.say
    section = ctx.settings.localization.scan
    kin = controller.kinematics.for_tool("laser")
    if scan_plan is None or scan_plan.mode == "fixed":
        raster = raster_for(section, controller.laser_directions_tcp)
        plan = plan_scan(
            kin, box, section, controller.read_joints(), model.T_base_table, raster=raster
        )
    else:  # the chosen passes, for the arm and table the cell now believes
        section = section.model_copy(update={"speed_m_s": scan_plan.speed_m_s})
        plan = replan(kin, box, section, scan_plan, model.T_base_table)
    say(f"scan plan: {len(plan)} passes at table positions {[p.table_position_m for p in plan]}")
    scan = execute_scan(controller, plan, section, say, model, ctx.hooks.detect)
    keep = crop_to_object(scan.points_table, box, section.crop_margin_m)
    say(
        f"scan: {len(scan.points_table)} points, {int(keep.sum())} on the object, "
        f"{scan.seconds:.1f} s of scan motions"
    )
    return ScanStage(scan, keep, scan.points_table[keep], plan, scan.seconds)


def job_scan_plan(
    robot: Robot,
    settings: PlanningSettings,
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
    say: Progress,
    target_names: tuple[str, ...] | None = None,
) -> ScanPlan:
    """The job's scan plan in its virtual cell (scenarios.offline.scan_plan) with the nominal
    arm and table, for the operation targets (K, 3, model frame) named `target_names`."""
    section = settings.localization.scan
    registration = settings.localization.registration
    pass_sigma = registration.pass_sigma_m if registration.pass_sigma_m is not None else 0.0
    name = settings.object_name
    cell = job_virtual_cell(
        robot, settings.rack_xyz, virtual, T_table_object, settings.calibration.enabled, name
    )
    laser = settings.laser.data_sheet()  # the laser's data sheet: rays, range, grazing limit
    kin = robot.kinematics().for_tool("laser")
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    noise = section.planning.range_sigma_m

    def unambiguous(points_table: np.ndarray, labels: np.ndarray) -> bool:
        """Whether the job's match finds one pose, the right one, in a scan of these points
        (the laser's range noise added, seeded)."""
        rng = np.random.default_rng(settings.seed)
        noisy = points_table + rng.normal(0.0, noise, points_table.shape)
        located = localize(
            noisy, shape, registration.max_points, acceptance(settings), settings.seed,
            registration.voxel_m, registration.mode,
            passes=scan_passes(labels, registration.pass_sigma_m), targets_model=targets_model,
        )  # fmt: skip
        moved = transform_points(located.T_table_object, targets_model) - transform_points(
            T_table_object, targets_model
        )
        return located.result.verdict == "accepted" and float(
            np.max(np.linalg.norm(moved, axis=1))
        ) < max(1e-3, 10 * noise)

    plan = plan_job_scan(
        PlanningCell(
            kin, cell, ObjectBox.of(virtual.mesh.vertices, T_table_object), T_table_object,
            robot.q_home, robot.joint_speed,
            (laser.directions_tcp(), (laser.range_min_m, laser.range_max_m),
             laser.max_incidence_rad),
            object_name=name,
        ),
        section, error_model(section, registration.voxel_m, registration.max_points, pass_sigma),
        targets_model, say=say, unambiguous=unambiguous, target_names=target_names,
        acceptable_tre_m=registration.max_predicted_tre_m,
    )  # fmt: skip
    say(plan_summary(plan))
    return plan


def plan_summary(plan: ScanPlan) -> str:
    """The scan plan in one line: its mode, passes, time and worst predicted TRE."""
    return (
        f"scan plan ({plan.mode}): {len(plan.passes)} passes, about {plan.predicted_time_s:.0f} s"
        f", worst predicted TRE {plan.predicted_tre_max_m * 1e3:.3f} mm"
    )


@dataclass(frozen=True)
class Scanned(Outcome):
    """The scan, the latest of the job's."""

    scan: ScanStage

    def advance(self, state: JobState) -> JobState:
        return replace(state, scanned=self.scan)


@dataclass(frozen=True, eq=False)
class Scan:
    """The stage "scan": the passes of the job's `plan` (chosen in its virtual cell before
    the real one was built; None: the fixed passes, planned now) run with the cell model the
    job believes."""

    plan: ScanPlan | None = None
    name: str = "scan"
    title: str = "the laser's passes over the object"

    def due(self, ctx: StageContext) -> bool:
        return True

    def run(self, ctx: StageContext) -> Scanned:
        return Scanned(scan_stage(ctx, ctx.state.model, self.plan))
