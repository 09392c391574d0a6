"""Run a RAPID program's execution plan (scenarios.rapid.planner) on the cell the way an ABB
IRC5 controller without the absolute-accuracy option runs it.

`execute_plan` changes to the cell's tool the program's tooldata stands for, goes to the
start configuration, and runs the moves with the controller: MoveJ and MoveAbsJ as joint
moves at the speed fraction that gives the programmed TCP speed, MoveL as straight moves
with the program's tooldata TCP at v_tcp. A stop point settles (SETTLE_S, or the stoptime
of its \\Inpos stoppointdata), a fly-by point does not (the cell's controller reaches it
without blending the corner); a move after MotionSup \\Off runs with the supervision off.
At each MoveL to a stop point (a touch) it calls `on_touch(target)`.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from cell import Controller
from cell.cell_errors import CellError, MotionHaltedError
from cell.controller import SETTLE_S
from scenarios.program.tool_change import change_tool_safely
from scenarios.rapid.execution_plan import ExecutionPlan, PlannedMove
from scenarios.scenario_errors import ScenarioError


class ExecutionError(ScenarioError, RuntimeError):
    """A planned program that the cell could not run (a move failed on the cell), or a plan
    handed to a controller it was not made for."""


@dataclass(frozen=True, eq=False)
class ExecutedMove:
    """A move as the cell ran it: the plan's move, the encoders after it q_measured (6,)
    [rad], the TCP they give with the controller's kinematics T_base_tcp_measured (4, 4) [m]
    (where the controller believes the TCP is), and the controller's clock [s]."""

    move: PlannedMove
    q_measured: np.ndarray
    T_base_tcp_measured: np.ndarray
    time_s: float


@dataclass(frozen=True, eq=False)
class ExecutionRecord:
    """What `execute_plan` did: the plan, each move as run, and the controller's clock at
    the start (before the tool change) and at the end [s]."""

    plan: ExecutionPlan
    moves: tuple[ExecutedMove, ...]
    start_time_s: float
    end_time_s: float

    @property
    def touches(self) -> tuple[ExecutedMove, ...]:
        return tuple(m for m in self.moves if m.move.touch)


def execute_plan(
    controller: Controller,
    plan: ExecutionPlan,
    on_touch: Callable[[str], None] | None = None,
    on_move: Callable[[str], None] | None = None,
) -> ExecutionRecord:
    """Run `plan` on the cell (see the module's docstring): change to the plan's tool (through
    home), joint move to q_start, then every move; `on_touch(target)` after each MoveL to a
    stop point, `on_move(what)` after every motion. The controller must move with the
    kinematics the plan was made with (checked before any motion: an IRC5 without absolute
    accuracy moves with its nominal arm). Raises ExecutionError naming the line if a move
    fails on the cell."""
    touched = on_touch or (lambda _target: None)
    start = controller.time_s
    start_plan(controller, plan, on_move)
    done = []
    for move in plan.moves:
        done.append(run_move(controller, plan, move, on_move))
        if move.touch:
            touched(move.target)
    return ExecutionRecord(plan, tuple(done), start, controller.time_s)


def start_plan(
    controller: Controller,
    plan: ExecutionPlan,
    on_move: Callable[[str], None] | None = None,
    from_here: bool = False,
) -> None:
    """What a plan's execution does before its first move: check that the controller is the
    one it was planned for (its tools, its kinematics), change to the plan's tool (through
    home) and joint move to q_start; `on_move(what)` after each motion. `from_here`: the
    plan starts where the arm stands (a controller plans a program from there), and only a
    tool change takes the arm back to q_start."""
    moved = on_move or (lambda _what: None)
    if plan.tool is not None and plan.tool not in controller.tools:
        raise ExecutionError(
            f"{plan.source}: the plan needs the {plan.tool}, which this cell does not have "
            f"(its tools: {', '.join(controller.tools)})"
        )
    gap = np.max(np.abs(controller.kinematics.fk(plan.q_start) - plan.T_base_flange_start))
    if gap > 1e-9:
        raise ExecutionError(
            f"{plan.source}: the plan was made with other kinematics than the controller "
            f"moves with (the flange at the start differs by {gap:.3g}); plan with "
            "controller.kinematics"
        )
    changed = plan.tool is not None and controller.tool_in_hand != plan.tool
    if changed:
        assert plan.tool is not None
        change_tool_safely(controller, plan.tool)
        moved("tool change")
    if changed or not from_here:
        controller.move_joints(plan.q_start)
        moved("start")


def run_move(
    controller: Controller,
    plan: ExecutionPlan,
    move: PlannedMove,
    on_move: Callable[[str], None] | None = None,
) -> ExecutedMove:
    """Run one planned move on the cell (the table first if the move sets it) and read the
    encoders after it; `on_move(what)` after each motion. Raises ExecutionError naming the
    line if the move fails on the cell; a halt asked from outside (MotionHaltedError) passes."""
    moved = on_move or (lambda _what: None)
    settle = 0.0
    if move.stop:
        settle = SETTLE_S if move.stop_time_s is None else move.stop_time_s
    try:
        table = move.table_position_m
        if table is not None and abs(controller.table_position() - table) > 1e-9:
            controller.move_table(table)
            moved("table")
        with nullcontext() if move.supervised else controller.supervision_off():
            if move.instruction == "MoveL":
                controller.move_linear(
                    move.T_base_tcp, move.v_tcp_m_s, move.v_ori_rad_s, settle, move.T_flange_tcp
                )
            else:
                controller.move_joints(move.q, move.speed_fraction, settle)
    except MotionHaltedError:
        raise
    except CellError as exc:
        raise ExecutionError(
            f"{move.source or plan.source}:{move.line}: {move.instruction} {move.target} "
            f"failed on the cell: {exc}"
        ) from exc
    moved(f"{move.instruction} {move.target}")
    q = controller.read_joints()
    T_measured = controller.kinematics.fk(q) @ move.T_flange_tcp
    return ExecutedMove(move, q, T_measured, controller.time_s)
