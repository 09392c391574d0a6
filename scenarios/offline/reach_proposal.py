"""A change to propose where the virtual cell's arm cannot do a job (scenarios.offline.reach):
the rack moved towards the cell's design place for it until its slots are reached, or the
object moved towards the arm on the table, or turned on it, until the rack, the scan and the
operations are; each proposed only once the reach check passes with it and the operations'
program, planned at the object's nominal pose, passes the pre-motion check from home, said
as the setting to change.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from cell.robot_arm import Robot
from models.model import ObjectModel
from models.robot import RACK_POS, TOOLS
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.premotion import check_program
from scenarios.offline.premotion_verdict import PremotionLimits
from scenarios.offline.program_plan import plan_program
from scenarios.offline.program_proposal import TURNS_DEG
from scenarios.offline.reach import check_reach
from scenarios.offline.scan_passes import ObjectBox
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.table_candidates import UnreachablePlanError
from scenarios.program.program_types import Operation

#: How far the object is tried nearer the arm, along the table's x [m], and the turns of it
#: about the vertical tried [deg].
NEARER_M = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5)
#: The fractions of the way from the given rack to the cell's design place tried.
RACK_STEPS = (0.25, 0.5, 0.75, 1.0)


def turned_yaw_deg(yaw_deg: float, turn_deg: float) -> float:
    """A part's yaw [deg] turned `turn_deg` further, in (-180, 180]."""
    return float((yaw_deg + turn_deg + 180.0) % 360.0 - 180.0)


def _rounded(values: np.ndarray) -> list[float]:
    return [round(float(v), 3) + 0.0 for v in values]


def _candidates(
    settings: PlanningSettings, move_object: bool
) -> Iterator[tuple[str, PlanningSettings]]:
    """The changed settings tried, in order (the object's place only if `move_object`), and
    the change as a `--set` says it."""
    rack = np.asarray(settings.rack_xyz, dtype=float)
    for step in RACK_STEPS:
        moved = _rounded(rack + step * (np.asarray(RACK_POS) - rack))
        yield f"cell.rack_xyz={moved}", settings.model_copy(update={"rack_xyz": tuple(moved)})
    if not move_object:
        return
    placement = settings.placement
    x, y = placement.xy_m
    for nearer in NEARER_M:
        xy = _rounded(np.array([x - nearer, y]))
        changed = placement.model_copy(update={"xy_m": tuple(xy)})
        yield f"cell.object.placement.xy_m={xy}", settings.model_copy(update={"placement": changed})
    for turn in TURNS_DEG:
        yaw = turned_yaw_deg(placement.yaw_deg, turn)
        changed = placement.model_copy(update={"yaw_deg": yaw})
        yield (
            f"cell.object.placement.yaw_deg={yaw:g}",
            settings.model_copy(update={"placement": changed}),
        )


def _passes(
    robot: Robot,
    settings: PlanningSettings,
    virtual: ObjectModel,
    operations: tuple[Operation, ...],
    pick: Operation | None,
    table_positions: tuple[float, ...] | None,
) -> bool:
    """Whether `robot` reaches what the job of `settings` needs and its operations' program
    at the object's nominal pose passes the pre-motion check from home."""
    T_table_object = nominal_pose(settings.placement, virtual.mesh.vertices)
    box = ObjectBox.of(virtual.mesh.vertices, T_table_object)
    try:
        reach = check_reach(robot, settings, box, T_table_object, operations, pick, table_positions)
    except UnreachablePlanError:
        return False
    tool = settings.operations.tool
    kin = robot.kinematics().for_tool(tool)
    T_tcp = next(t for t in TOOLS if t.name == tool).T_tool_tcp
    spins = settings.operations.spins if table_positions is None else 1
    margin, table = PremotionLimits().joint_margin_rad, (reach.operations_table_m or 0.0,)
    try:
        program = plan_program(kin, T_tcp, tool, operations, T_table_object, robot.q_home, spins,
                               table, joint_margin_rad=margin)  # fmt: skip
    except UnreachablePlanError:
        return False
    cell = job_virtual_cell(robot, settings.rack_xyz, virtual, T_table_object,
                            settings.calibration.enabled, settings.object_name)  # fmt: skip
    check = check_program(program, kin, cell, robot.q_home, T_tcp, object_name=settings.object_name)
    return check.ok


def reach_proposal(
    robot: Robot,
    settings: PlanningSettings,
    virtual: ObjectModel,
    operations: tuple[Operation, ...],
    pick: Operation | None = None,
    table_positions: tuple[float, ...] | None = None,
) -> str | None:
    """The first change (see the module's docstring) with which `robot` does the job of
    `settings` (the object's `virtual` model, its `operations` and `pick`) in the virtual
    cell, as "KEY=VALUE", or None where none does. A user's program
    (its robtargets taught at `table_positions` [m]) fixes the object's place by its work
    object: it is offered a move of the rack only."""
    for change, trial in _candidates(settings, table_positions is None):
        if _passes(robot, trial, virtual, operations, pick, table_positions):
            return change
    return None
