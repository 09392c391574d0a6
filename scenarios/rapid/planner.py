"""Plan a RAPID module for the cell the way an ABB IRC5 controller without the
absolute-accuracy option runs it: every target solved with the arm's NOMINAL kinematics, so
that a program that cannot run is refused before anything moves (scenarios.rapid.executor
runs the plan).

`plan_execution` walks the program from `main` in the order the controller runs it
(scenarios.rapid.flow) and resolves every move: its tool, its work object, the target in the
base frame T_base_tcp = T_base_uframe @ T_uframe_oframe @ T_wobj_tcp, the table, the speed,
the zone (scenarios.rapid.move_data) and the joints: MoveJ solves the target in the
robtarget's confdata, MoveL follows the straight line from the previous point and must end in
the robtarget's confdata (ConfL\\On), MoveAbsJ takes its jointtarget [deg]
(scenarios.rapid.nominal_motion); a move after MotionSup \\Off runs with the motion
supervision off (until MotionSup \\On). A RapidError `<file>:<line>: <what>` names the first move or
instruction that cannot run.

The program is a module or a task of several modules (scenarios.rapid.task): `main` runs
wherever it is defined, each statement sees its own module's data and the task's global data.
RAPID instructions that do not move the arm (messages, I/O, files, sockets, waits, load and
acceleration settings: scenarios.rapid.instructions) are listed in the plan as skipped; a
motion instruction other than MoveJ, MoveL and MoveAbsJ (MoveC: the cell's controller has no
circular moves; searches, triggered and process moves, path and offset control), a procedure
defined nowhere in the task, and a tooldata the cell has no tool for are refused.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from cell import Controller, Kinematics
from scenarios.rapid.confdata import Conf
from scenarios.rapid.execution_plan import ExecutionPlan, PlannedMove
from scenarios.rapid.flow import Step, execution_order, program_error
from scenarios.rapid.instructions import is_instruction, is_motion
from scenarios.rapid.module import RapidModule
from scenarios.rapid.move_data import (
    FLANGE,
    PlanState,
    jointtarget,
    move_instruction,
    move_options,
    move_speed,
    move_tool,
    num_value,
    object_frame,
    stop_point,
    stop_time,
    table_position,
    target_data,
)
from scenarios.rapid.nominal_motion import solve_move, speed_fraction
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import ModuleScope, RapidTask, task_of

_COMPENSATION = re.compile(r"^[ \t]*![ \t]*compensation[ \t]*:[ \t]*([A-Za-z][\w-]*)", re.I | re.M)


def compensation(module: RapidModule) -> str:
    """The compensation a module states in a comment line `! compensation: <word>` (e.g.
    "filtered": its targets are corrected for the real arm), lower case; "nominal" if none."""
    found = _COMPENSATION.search(module.text)
    return found.group(1).lower() if found else "nominal"


def cell_tools(controller: Controller) -> dict[str, np.ndarray]:
    """The cell's tools and their nominal TCPs T_flange_tcp (4, 4) [m] (their data sheet)."""
    return {name: controller.T_flange_tcp(name) for name in controller.tools}


def _plan_move(
    module: ModuleScope,
    step: Step,
    kin: Kinematics,
    tools: Mapping[str, np.ndarray],
    joint_speed: np.ndarray,
    state: PlanState,
    seed: int,
) -> PlannedMove:
    """One move resolved for the nominal arm `kin` from the controller's `state` (updated:
    the joints and the table at its end)."""
    move = step.move
    assert move is not None
    line = step.line
    instruction = move_instruction(module, step)
    options = move_options(module, step, instruction)
    tool = move_tool(module, move.tool, tools, line, state)
    T_tcp = np.eye(4) if tool is None else tool.T_flange_tcp
    wobj, T_base_oframe = object_frame(module, move.wobj, line)
    v_tcp, v_ori = move_speed(module, move.speed, options, line, state)
    stop = stop_point(module, move.zone, options, line)
    conf: Conf | None = None
    if instruction == "MoveAbsJ":
        q, eax_a = jointtarget(module, step, kin)
        T_base_tcp = kin.fk(q) @ T_tcp
    else:
        if move.T_wobj_tcp is None:
            declared = {n.casefold() for n in module.data}
            why = "the target is known only when the program runs"
            named = re.fullmatch(r"[A-Za-z_]\w*", move.target) is not None
            if module.opaque and named and move.target.casefold() not in declared:
                why = module.undeclared(f"the target {move.target}")
            raise program_error(module, line, f"{instruction} {move.target}: {why}")
        target_conf, eax_a = target_data(module, step)
        T_base_tcp = T_base_oframe @ move.T_wobj_tcp
        monitored = state.conf_j if instruction == "MoveJ" else state.conf_l
        conf = target_conf if monitored else None
        q = solve_move(module, step, kin, T_base_tcp, T_tcp, conf, target_conf, state, seed)
    table = table_position(module, eax_a, line, state)
    fraction = 1.0
    if instruction != "MoveL":
        fraction = speed_fraction(kin, state.q, q, T_tcp, v_tcp, v_ori, joint_speed)
    planned = PlannedMove(
        instruction,
        move.target,
        line,
        step.routine,
        FLANGE if tool is None else tool.name,
        wobj,
        np.array(T_tcp, dtype=float),
        T_base_oframe,
        T_base_tcp,
        conf,
        q,
        table,
        v_tcp,
        v_ori,
        fraction,
        stop,
        instruction == "MoveL" and stop,
        module.label,
        stop_time(module, options, line) if stop else None,
        state.supervised,
    )
    state.q, state.table_m = q, table
    return planned


def plan_execution(
    program: RapidModule | RapidTask,
    kinematics: Kinematics,
    tools: Mapping[str, np.ndarray],
    q_start: np.ndarray,
    joint_speed_rad_s: np.ndarray,
    entry: str = "main",
    seed: int = 0,
) -> ExecutionPlan:
    """Plan a module or a task from its PROC `entry` (in whichever module it is) for an arm
    with `kinematics` (the controller's nominal kinematics: an IRC5 without absolute
    accuracy) and joint speed limits `joint_speed_rad_s` (6,), starting at q_start (6,)
    [rad], in a cell with `tools` (name -> nominal T_flange_tcp (4, 4), see `cell_tools`).
    `seed`: the IK's random seeds. Raises RapidError `<file>:<line>: <what>` for anything
    that cannot run (see the module's docstring); nothing moves."""
    task = program if isinstance(program, RapidTask) else task_of(program)
    steps = execution_order(task, entry)
    q0 = kinematics.check_limits(np.array(q_start, dtype=float))
    state = PlanState(q=q0)
    speeds = np.asarray(joint_speed_rad_s, dtype=float)
    moves: list[PlannedMove] = []
    skipped: list[str] = []
    scopes: dict[int, ModuleScope] = {}
    for step in steps:
        assert step.module is not None
        scope = scopes.setdefault(id(step.module), task.scope(step.module))
        if step.move is not None:
            moves.append(_plan_move(scope, step, kinematics, tools, speeds, state, seed))
        elif not _set_state(scope, step, state):
            _check_skipped(scope, step)
            skipped.append(f"line {step.line}: {step.instruction}")
    main = task.procedure(entry, task.modules[0])
    assert main is not None  # execution_order found it
    if not moves:
        raise RapidError(f"{main.label}: PROC {entry} runs no MoveJ, MoveL or MoveAbsJ")
    return ExecutionPlan(
        # the file of the module main is in, or the folder of a task of several modules
        main.label if len(task.modules) == 1 or task.path is None else task.label,
        main.name,
        _task_compensation(task, main),
        state.cell_tool,
        q0,
        kinematics.fk(q0),
        tuple(moves),
        tuple(skipped),
    )


def _set_state(module: ModuleScope, step: Step, state: PlanState) -> bool:
    """Apply ConfJ, ConfL, MotionSup or VelSet to `state`; False for any other instruction."""
    name = step.instruction.casefold()
    if name == "motionsup":
        switch = {o.partition(":=")[0].lstrip("\\").strip().casefold() for o in step.options}
        if not ({"on"} <= switch <= {"on", "tunevalue"} or switch == {"off"}):
            raise program_error(module, step.line, "MotionSup needs \\On or \\Off")
        state.supervised = "on" in switch
        return True
    if name in ("confj", "confl"):
        switch = {o.lstrip("\\").strip().casefold() for o in step.options}
        if switch not in ({"on"}, {"off"}):
            raise program_error(module, step.line, f"{step.instruction} needs \\On or \\Off")
        if name == "confj":
            state.conf_j = switch == {"on"}
        else:
            state.conf_l = switch == {"on"}
        return True
    if name == "velset":
        if len(step.arguments) != 2:
            raise program_error(module, step.line, "VelSet needs Override [%] and Max [mm/s]")
        override = num_value(module, step.arguments[0], step.line, "the VelSet override")
        v_max = num_value(module, step.arguments[1], step.line, "the VelSet maximum speed")
        if not (override > 0.0 and v_max > 0.0):
            raise program_error(module, step.line, "VelSet's override and maximum must be > 0")
        state.override, state.v_max_m_s = override / 100.0, v_max * 1e-3
        return True
    return False


def _check_skipped(module: ModuleScope, step: Step) -> None:
    """An instruction that is not a move the executor runs may be skipped only if it is a
    RAPID instruction that does not move the arm (see the module's docstring)."""
    if step.instruction.startswith("<"):
        raise program_error(
            module,
            step.line,
            f"the placeholder {step.instruction} stands for a statement not written yet: a "
            "controller stops here with an error",
        )
    if is_motion(step.instruction):
        raise program_error(
            module,
            step.line,
            f"{step.instruction} is not executed: it moves the arm or changes its path, and "
            "the cell's controller runs MoveJ, MoveL and MoveAbsJ only (no searches, no "
            "triggered or process moves, no path or offset control)",
        )
    if not is_instruction(step.instruction):
        where = "the task" if not module.opaque else "the task's readable modules"
        maybe = ""
        if module.opaque:
            maybe = f" (the encrypted module(s) {module.opaque_names} may define it, unread here)"
        raise program_error(
            module,
            step.line,
            f"unknown instruction {step.instruction!r}: neither a PROC of {where} nor a "
            f"RAPID instruction{maybe}; the executor cannot tell whether it moves the arm",
        )


def _task_compensation(task: RapidTask, main: RapidModule) -> str:
    """The compensation the task states: main's module first, then the others in order."""
    for module in (main, *(m for m in task.modules if m is not main)):
        stated = compensation(module)
        if _COMPENSATION.search(module.text):
            return stated
    return "nominal"
