"""The offline program: operations authored on the virtual model, corrected by the measured
object pose, solved with the nominal inverse kinematics, and executed on the real cell.

An operation is a tool pose at touch in the OBJECT frame (z along the approach, into the
object) and an approach distance. Correction is one product: T_base_tcp = T_base_table(s) @
T_table_object @ T_object_tcp, where T_table_object comes from the surface matching and s is
the table position the program runs at.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell import Controller, Kinematics, nominal_T_base_table
from cell.cell_errors import CellError
from models.robot import TABLE_TRAVEL
from models.targets import BurrHole
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M, UnreachablePlanError
from scenarios.program.program_types import (
    ExecutedOperation,
    OfflineProgram,
    Operation,
    PlannedOperation,
)
from scenarios.program.tool_change import change_tool_safely


def _frame_from_z(p: np.ndarray, z_axis: np.ndarray) -> np.ndarray:
    z = z_axis / np.linalg.norm(z_axis)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - (ref @ z) * z
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, p
    return T


def burr_hole_operations(
    holes: tuple[BurrHole, ...], approach_m: float, touch_offset_m: float
) -> tuple[Operation, ...]:
    """One touch per burr hole: the tip `touch_offset_m` [m] before the entry on the
    trajectory, the tool axis along the trajectory."""
    return tuple(
        Operation(
            hole.name,
            _frame_from_z(hole.p_entry - touch_offset_m * hole.direction, hole.direction),
            approach_m,
        )
        for hole in holes
    )


def spun(T: np.ndarray, angle: float) -> np.ndarray:
    """T (4, 4) turned `angle` [rad] about its own z axis (a tool's spin about its axis)."""
    c, s = np.cos(angle), np.sin(angle)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = T.copy()
    out[:3, :3] = T[:3, :3] @ Rz
    return out


def _wrist_flipped(q: np.ndarray) -> np.ndarray:
    """(6,) the same flange pose on the wrist's other branch: joint 4 and 6 half a turn
    round (towards zero), joint 5 mirrored."""
    out = np.array(q, dtype=float)
    out[3] -= np.copysign(np.pi, out[3])
    out[4] = -out[4]
    out[5] -= np.copysign(np.pi, out[5])
    return out


def _plan_at(
    kin: Kinematics,
    T_tcp: np.ndarray,
    operations: tuple[Operation, ...],
    T_base_object: np.ndarray,
    q_seed: np.ndarray,
    spins: int,
    joint_margin_rad: float = 0.0,
) -> tuple[PlannedOperation, ...] | None:
    lower, upper = kin.lower + joint_margin_rad, kin.upper - joint_margin_rad

    def inside(q: np.ndarray) -> bool:
        return bool(np.all(q >= lower) and np.all(q <= upper))

    planned = []
    q_prev = q_seed
    for op in operations:
        best: tuple[float, PlannedOperation] | None = None
        for k in range(spins):
            angle = 2 * np.pi * k / spins
            T_touch_obj = spun(op.T_object_touch, angle)
            T_app_obj = spun(op.T_object_approach, angle)
            T_base_app = T_base_object @ T_app_obj
            T_base_touch = T_base_object @ T_touch_obj
            r_app = kin.ik(T_base_app, q_prev, T_tcp, extra_seeds=4)
            if not (r_app.success and inside(r_app.q)):  # the wrist's other branch
                r_app = kin.ik(T_base_app, _wrist_flipped(q_prev), T_tcp, extra_seeds=0)
            if not r_app.success or not inside(r_app.q):
                continue
            r_touch = kin.ik(T_base_touch, r_app.q, T_tcp, extra_seeds=0)
            if not r_touch.success or np.max(np.abs(r_touch.q - r_app.q)) > 0.5:
                continue
            if not inside(r_touch.q):
                continue
            cost = float(np.sum(np.abs(r_app.q - q_prev)))
            if best is None or cost < best[0]:
                best = (
                    cost,
                    PlannedOperation(
                        op,
                        angle,
                        T_touch_obj,
                        T_app_obj,
                        T_base_app,
                        T_base_touch,
                        r_app.q,
                        r_touch.q,
                    ),
                )
        if best is None:
            return None
        planned.append(best[1])
        q_prev = best[1].q_approach
    return tuple(planned)


def plan_program(
    kin: Kinematics,
    tool_T_flange_tcp: np.ndarray,
    tool: str,
    operations: tuple[Operation, ...],
    T_table_object: np.ndarray,
    q_seed: np.ndarray,
    spins: int = 12,
    table_positions: tuple[float, ...] = TABLE_CANDIDATES_M,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
    joint_margin_rad: float = 0.0,
) -> OfflineProgram:
    """Correct every operation by the measured `T_table_object` and solve it, at the first
    of `table_positions` [m] where the arm reaches them all, the table frame there from
    `table` (the cell model's; default the nominal) (spin about the tool axis chosen
    for the least joint motion; `spins=1` keeps the operations' own orientation), the
    approach and touch joints `joint_margin_rad` [rad] inside the joint ranges (those the
    pre-motion check holds them to)."""
    lo, hi = TABLE_TRAVEL
    for s in table_positions:
        if not lo <= s <= hi:
            continue
        T_base_table = table(s)
        T_base_object = T_base_table @ T_table_object
        planned = _plan_at(
            kin, tool_T_flange_tcp, operations, T_base_object, q_seed, spins, joint_margin_rad
        )
        if planned is not None:
            return OfflineProgram(tool, s, T_table_object.copy(), planned, T_base_table)
    raise UnreachablePlanError(
        f"the {len(operations)} operations ({', '.join(o.name for o in operations)}) are not "
        f"all reachable at any table position of {table_positions} m"
    )


def execute_program(
    controller: Controller,
    program: OfflineProgram,
    touch_speed_m_s: float,
    on_touch: Callable[[str], None] | None = None,
    on_move: Callable[[str], None] | None = None,
    T_flange_tcp: np.ndarray | None = None,
) -> tuple[ExecutedOperation, ...]:
    """Change to the program's tool, move the table, then for each operation: joint move to
    the approach, straight move to the touch, `on_touch(name)`, straight move back. The
    straight moves take the tool's TCP as `T_flange_tcp` (4, 4) has it (a TCP measured at
    the beam), else its tooldata."""
    touched = on_touch or (lambda _name: None)
    moved = on_move or (lambda _what: None)
    change_tool_safely(controller, program.tool)
    moved("tool change")
    if abs(controller.table_position() - program.table_position_m) > 1e-6:
        controller.move_table(program.table_position_m)
    done = []
    for planned in program.operations:
        name = planned.operation.name
        try:
            controller.move_joints(planned.q_approach)
            moved(f"{name}: approach")
            controller.move_linear(
                planned.T_base_touch, speed_m_s=touch_speed_m_s, T_flange_tcp=T_flange_tcp
            )
        except CellError as exc:
            raise UnreachablePlanError(f"operation {name!r} failed on the cell: {exc}") from exc
        touched(name)
        moved(f"{name}: touch")
        T_tcp = controller.T_flange_tcp() if T_flange_tcp is None else T_flange_tcp
        T_base_tcp = controller.kinematics.fk(controller.read_joints()) @ T_tcp
        done.append(ExecutedOperation(name, T_base_tcp, controller.time_s))
        controller.move_linear(planned.T_base_approach, speed_m_s=0.1, T_flange_tcp=T_flange_tcp)
        moved(f"{name}: retract")
    return tuple(done)
