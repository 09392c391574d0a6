"""Before the cell starts: can this arm do this job in this layout at all?

The check runs in the virtual cell only (the arm's nominal kinematics, the rack's and the
object's nominal places): every tool the job uses must be reachable in its rack slot, every
scan pass must be plannable at some table position, and the operations must be solvable at
the object's nominal pose. A job that fails here is refused with what is out of reach and
what to move, before any simulation; one that passes may still meet an object lying far
from its nominal pose, which the stages then report themselves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import nominal_T_base_slot
from cell.controller import RACK_APPROACH_M
from cell.robot_arm import Robot
from models.robot import TOOLS
from scenarios.offline.program_plan import plan_program
from scenarios.offline.scan_passes import ObjectBox, plan_scan, raster_for
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M, UnreachablePlanError
from scenarios.program.program_types import Operation

_TCP = {t.name: t.T_tool_tcp for t in TOOLS}


@dataclass(frozen=True)
class ReachPlan:
    """What the check found: the tools the job uses, the table position [m] of each scan
    pass, and that of the operations (None where the job has none)."""

    tools: tuple[str, ...]
    scan_tables_m: tuple[float, ...]
    operations_table_m: float | None


def _what_to_move(robot: Robot) -> str:
    return (
        f"the {robot.name} cannot do this job in this cell; move the arm nearer what it misses "
        "(cell.robot.mount_xyz), the rack nearer the arm (cell.rack_xyz) or the object "
        "(cell.object.placement.xy_m), or widen the joint window the solutions must keep "
        "(cell.robot.limits_deg; its home, cell.robot.home_deg, picks the branch)"
    )


def job_tools(config: PlanningSettings) -> tuple[str, ...]:
    """The tools a job changes to, in the order it uses them."""
    tools = []
    if config.calibration.enabled or "surface" in config.localization.methods:
        tools.append("laser")
    if "probe" in config.localization.methods:
        tools.append("ir")
    if config.operations.pick is not None:
        tools.append("gripper")
    tools.append(config.operations.tool)
    return tuple(dict.fromkeys(tools))


def check_slots(robot: Robot, rack_xyz: tuple[float, float, float], tools: tuple[str, ...]) -> None:
    """Each tool's rack slot (the flange seated on it, and the approach above it) must be
    reachable from home; raises UnreachablePlanError naming the slots that are not."""
    kin = robot.kinematics()
    out = []
    for tool in tools:
        T_slot = nominal_T_base_slot(tool, rack_xyz)
        T_above = T_slot.copy()
        T_above[2, 3] += RACK_APPROACH_M
        above = kin.ik(T_above, robot.q_home, extra_seeds=12)
        seat = kin.ik(T_slot, above.q, extra_seeds=0) if above.success else None
        if seat is None or not seat.success:
            out.append(f"{tool} at {np.round(T_slot[:3, 3], 3).tolist()} m")
    if out:
        raise UnreachablePlanError(f"{_what_to_move(robot)}: rack slots out of reach: {out}")


def check_reach(
    robot: Robot,
    config: PlanningSettings,
    box: ObjectBox,
    T_table_object: np.ndarray,
    operations: tuple[Operation, ...],
    pick: Operation | None = None,
    table_positions: tuple[float, ...] | None = None,
) -> ReachPlan:
    """The job's reach in the virtual cell (see the module's docstring): the rack slots of
    its tools, its scan passes over the object's nominal box, its `operations` (and `pick`)
    at the object's nominal pose T_table_object (4, 4) [m], at `table_positions` [m] if the
    program fixes them. Raises UnreachablePlanError naming what is out of reach."""
    tools = job_tools(config)
    check_slots(robot, config.rack_xyz, tools)
    kin = robot.kinematics()
    q = robot.q_home
    scan_tables: tuple[float, ...] = ()
    try:
        if "surface" in config.localization.methods:
            scan = config.localization.scan
            raster = raster_for(scan, config.laser.data_sheet().directions_tcp())
            plan = plan_scan(kin, box, scan, q, raster=raster)
            scan_tables = tuple(p.table_position_m for p in plan)
        if pick is not None:
            plan_program(kin, _TCP["gripper"], "gripper", (pick,), T_table_object, q, spins=2)
        section = config.operations
        program = plan_program(
            kin,
            _TCP[section.tool],
            section.tool,
            operations,
            T_table_object,
            q,
            section.spins if table_positions is None else 1,
            TABLE_CANDIDATES_M if table_positions is None else table_positions,
        )
    except UnreachablePlanError as exc:
        raise UnreachablePlanError(f"{_what_to_move(robot)}: {exc}") from None
    return ReachPlan(tools, scan_tables, program.table_position_m)
