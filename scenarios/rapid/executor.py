"""Run a RAPID module on the cell the way an ABB IRC5 controller without the
absolute-accuracy option runs it: every target solved with the arm's NOMINAL kinematics.

Two steps, so that a program that cannot run is refused before anything moves:

- `plan_execution` walks the program from `main` in the order the controller runs it
  (scenarios.rapid.flow) and resolves every move: its tool (a declared tooldata, or
  tool0, the flange), its work object (a declared wobjdata with a fixed user frame, or wobj0,
  the base frame), the target in the base frame T_base_tcp = T_base_uframe @ T_uframe_oframe
  @ T_wobj_tcp, the table (external axis A [mm]; 9E+09 leaves it where it is), the speed
  (speeddata v_tcp [mm/s] and v_ori [deg/s], predefined or declared, \\V:=, VelSet), the zone
  (fine or \\Inpos: a stop point; zNN: a fly-by point) and the joints: MoveJ solves the target
  in the robtarget's confdata (scenarios.rapid.confdata), MoveL follows the straight line
  from the previous point and must end in the robtarget's confdata (ConfL\\On), MoveAbsJ takes
  its jointtarget [deg]. A RapidError `<file>:<line>: <what>` names the first move or
  instruction that cannot run.
- `execute_plan` changes to the cell's tool the program's tooldata stands for, goes to the
  start configuration, and runs the moves with the controller: MoveJ and MoveAbsJ as joint
  moves at the speed fraction that gives the programmed TCP speed, MoveL as straight moves
  with the program's tooldata TCP at v_tcp. A stop point settles, a fly-by point does not (the
  cell's controller reaches it without blending the corner). At each MoveL to a stop point
  (a touch) it calls `on_touch(target)`.

The program is a module or a task of several modules (scenarios.rapid.task): `main` runs
wherever it is defined, each statement sees its own module's data and the task's global data.
RAPID instructions that do not move the arm (messages, I/O, files, sockets, waits, load and
acceleration settings: scenarios.rapid.instructions) are listed in the plan as skipped; a
motion instruction other than MoveJ, MoveL and MoveAbsJ (MoveC: the cell's controller has no
circular moves; searches, triggered and process moves, path and offset control), a procedure
defined nowhere in the task, and a tooldata the cell has no tool for are refused.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from cell import Controller, Kinematics
from cell.controller import SETTLE_S
from cell.errors import CellError, MotionHaltedError
from cell.trajectory import straight_path
from models.robot import TABLE_TRAVEL
from scenarios.errors import ScenarioError
from scenarios.offline.moves import change_tool_safely
from scenarios.rapid.confdata import Conf, honours, solve_in_configuration
from scenarios.rapid.flow import Step, execution_order, program_error
from scenarios.rapid.instructions import is_instruction, is_motion
from scenarios.rapid.module import RapidModule, ToolData
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import ModuleScope, RapidTask, task_of
from scenarios.rapid.writer import configuration, rapid_identifier

#: Predefined speeddata: name -> (v_tcp [mm/s], v_ori [deg/s]) (v_leax, v_reax unused here).
SPEEDS: dict[str, tuple[float, float]] = {
    **{
        f"v{v}": (float(v), 500.0)
        for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800)
    },
    **{f"v{v}": (float(v), 500.0) for v in (1000, 1500, 2000, 2500, 3000, 4000, 5000, 6000, 7000)},
    "vmax": (5000.0, 500.0),
}
#: Predefined zonedata: fine (a stop point) and the fly-by zones zNN.
ZONES = frozenset(
    ["fine"] + [f"z{n}" for n in (0, 1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200)]
)
#: Optional arguments of a move the executor honours (\WObj, \V, \Inpos) or may ignore
#: (\Conc: the next instructions run while the arm moves; \Z: the zone's size; \ID;
#: \NoEOffs: no external-axis offsets are active).
MOVE_OPTIONS = ("WObj", "V", "Inpos", "Conc", "Z", "ID", "NoEOffs")
_MOVE_OPTIONS = frozenset(name.casefold() for name in MOVE_OPTIONS)
#: A tooldata matches a cell tool by name (the tool's name or the writer's tName) or, failing
#: that, as the only tool whose nominal TCP is within these of the tooldata's.
TOOL_MATCH_M = 5e-3
TOOL_MATCH_RAD = float(np.deg2rad(5.0))
#: Largest joint step between two samples of a straight move [rad] (the controller's).
MAX_JOINT_STEP_RAD = 0.5
_LINE_STEP_M = 2e-3
_LINE_STEP_RAD = float(np.deg2rad(1.0))
_MIN_SPEED_FRACTION = 1e-3
_UNUSED_AXIS = 8.9e9
_FLANGE = "tool0"
_BASE = "wobj0"
_COMPENSATION = re.compile(r"^[ \t]*![ \t]*compensation[ \t]*:[ \t]*([A-Za-z][\w-]*)", re.I | re.M)


class ExecutionError(ScenarioError, RuntimeError):
    """A planned program that the cell could not run (a move failed on the cell), or a plan
    handed to a controller it was not made for."""


@dataclass(frozen=True, eq=False)
class PlannedMove:
    """One move resolved for the nominal arm.

    Attributes:
        instruction: "MoveJ", "MoveL" or "MoveAbsJ"; target: the target as written.
        line, routine: where the move is written.
        tooldata, wobj: the tooldata's and work object's names ("tool0", "wobj0" if none).
        T_flange_tcp: (4, 4) the tooldata's TCP in the flange frame [m].
        T_base_oframe: (4, 4) the work object's object frame in the base frame [m].
        T_base_tcp: (4, 4) the target TCP pose in the base frame [m].
        conf: the confdata honoured (None: MoveAbsJ, or configuration monitoring off).
        q: (6,) the joints at the end of the move [rad].
        table_position_m: the table during the move [m] (None: left where it is).
        v_tcp_m_s, v_ori_rad_s: the programmed speeds after VelSet.
        speed_fraction: the fraction of the joints' speed limits of a joint move.
        stop: a stop point (fine, \\Inpos); touch: a MoveL to a stop point.
        source: the file (or module) the move is written in.
    """

    instruction: str
    target: str
    line: int
    routine: str
    tooldata: str
    wobj: str
    T_flange_tcp: np.ndarray
    T_base_oframe: np.ndarray
    T_base_tcp: np.ndarray
    conf: Conf | None
    q: np.ndarray
    table_position_m: float | None
    v_tcp_m_s: float
    v_ori_rad_s: float
    speed_fraction: float
    stop: bool
    touch: bool
    source: str = ""


@dataclass(frozen=True, eq=False)
class ExecutionPlan:
    """A module ready to run: the file it came from, its name, the compensation it states
    (`! compensation: <word>`, else "nominal"), the cell's tool it needs in hand (None: the
    program moves the flange only), the start configuration q_start (6,) [rad] and the
    flange pose there T_base_flange_start (4, 4) (the kinematics it was planned with), the
    moves, and the instructions run without effect ("line N: Name")."""

    source: str
    module: str
    compensation: str
    tool: str | None
    q_start: np.ndarray
    T_base_flange_start: np.ndarray
    moves: tuple[PlannedMove, ...]
    skipped: tuple[str, ...]

    @property
    def touches(self) -> tuple[PlannedMove, ...]:
        return tuple(m for m in self.moves if m.touch)


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


# ---------------------------------------------------------------------------------------------
# Data of the module


def compensation(module: RapidModule) -> str:
    """The compensation a module states in a comment line `! compensation: <word>` (e.g.
    "filtered": its targets are corrected for the real arm), lower case; "nominal" if none."""
    found = _COMPENSATION.search(module.text)
    return found.group(1).lower() if found else "nominal"


def cell_tools(controller: Controller) -> dict[str, np.ndarray]:
    """The cell's tools and their nominal TCPs T_flange_tcp (4, 4) [m] (their data sheet)."""
    return {name: controller.T_flange_tcp(name) for name in controller.tools}


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _numbers(text: str) -> list[float]:
    return [float(x) for x in re.findall(_NUMBER, text)]


def _declared(module: ModuleScope, name: str, datatype: str, line: int) -> object | None:
    """The literal value of module-level data `name` of `datatype`, None if not declared as
    one; raises (naming `line`, where it is used) if declared without a literal value."""
    for declared, d in module.data.items():
        if declared.casefold() == name.casefold() and d.datatype.casefold() == datatype:
            if d.value is None:
                raise program_error(
                    module,
                    line,
                    f"{datatype} {d.name} (line {d.line}) has no literal value; the executor "
                    "needs its value before the program runs",
                )
            return d.value
    return None


def _option(text: str) -> tuple[str, str | None]:
    """(name, value as written) of an optional argument such as "\\V:=300"."""
    name, assigned, value = text.lstrip("\\").strip().partition(":=")
    return name.strip(), (value.strip() or None) if assigned else None


def _number(module: ModuleScope, text: str, line: int, what: str) -> float:
    """A num argument: a literal or a num declared with a literal value."""
    if re.fullmatch(_NUMBER, text.strip()):
        return float(text)
    value = _declared(module, text.strip(), "num", line)
    if isinstance(value, float):
        return value
    raise program_error(module, line, f"{what} {text!r} is neither a number nor a declared num")


# ---------------------------------------------------------------------------------------------
# Planning


@dataclass
class _State:
    """What the controller carries from one instruction to the next."""

    q: np.ndarray
    table_m: float | None = None
    conf_j: bool = True
    conf_l: bool = True
    override: float = 1.0
    v_max_m_s: float = math.inf
    cell_tool: str | None = None
    cell_tool_line: int = 0


def _match_tool(
    module: ModuleScope, tool: ToolData, tools: Mapping[str, np.ndarray], line: int
) -> str:
    """The cell's tool a tooldata stands for (see TOOL_MATCH_M)."""
    for name in tools:
        if tool.name.casefold() in (name.casefold(), rapid_identifier(name, "t").casefold()):
            return name
    near = []
    for name, T in tools.items():
        dp = float(np.linalg.norm(T[:3, 3] - tool.T_flange_tcp[:3, 3]))
        R = T[:3, :3].T @ tool.T_flange_tcp[:3, :3]
        angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
        if dp <= TOOL_MATCH_M and angle <= TOOL_MATCH_RAD:
            near.append(name)
    if len(near) == 1:
        return near[0]
    p = ", ".join(f"{n} [{', '.join(f'{v * 1e3:g}' for v in T[:3, 3])}]" for n, T in tools.items())
    tcp = ", ".join(f"{v * 1e3:g}" for v in tool.T_flange_tcp[:3, 3])
    if not near:
        raise program_error(
            module,
            line,
            f"no tool of the cell matches tooldata {tool.name} (TCP [{tcp}] mm, declared at "
            f"line {tool.line}): neither by name nor within {TOOL_MATCH_M * 1e3:g} mm of a "
            f"tool's nominal TCP; the cell's tools (TCP [mm]): {p}",
        )
    raise program_error(
        module,
        line,
        f"tooldata {tool.name} (TCP [{tcp}] mm) is ambiguous: the tools {', '.join(near)} all "
        f"have their nominal TCP within {TOOL_MATCH_M * 1e3:g} mm of it; name the tooldata "
        "after one of them",
    )


def _tooldata(module: ModuleScope, name: str, line: int) -> ToolData | None:
    """The tooldata `name` (None: tool0, the flange)."""
    if name.casefold() == _FLANGE:
        return None
    for declared, tool in module.tools.items():
        if declared.casefold() == name.casefold():
            if not tool.robhold:
                raise program_error(
                    module,
                    line,
                    f"tooldata {tool.name} is a stationary tool (robhold FALSE, line "
                    f"{tool.line}); the cell's tools are held by the robot",
                )
            return tool
    _declared(module, name, "tooldata", line)  # declared without a literal value
    raise program_error(module, line, f"tooldata {name} is not declared in the task")


def _object_frame(module: ModuleScope, name: str | None, line: int) -> tuple[str, np.ndarray]:
    """(name, T_base_oframe (4, 4)) of a move's work object (None: wobj0, the base frame)."""
    if name is None or name.casefold() == _BASE:
        return _BASE, np.eye(4)
    for declared, w in module.wobjs.items():
        if declared.casefold() == name.casefold():
            if w.robhold:
                raise program_error(
                    module,
                    line,
                    f"work object {w.name} is held by the robot (robhold TRUE, line {w.line}); "
                    "the executor runs work objects fixed in the cell",
                )
            if w.ufmec.strip() or not w.ufprog:
                raise program_error(
                    module,
                    line,
                    f"work object {w.name} is moved by the mechanical unit {w.ufmec!r} (ufprog "
                    f"{str(w.ufprog).upper()}, line {w.line}); the cell's table is not a "
                    "coordinated axis: give the work object a fixed user frame (ufprog TRUE, "
                    'ufmec "")',
                )
            return w.name, w.T_base_uframe @ w.T_uframe_oframe
    _declared(module, name, "wobjdata", line)
    raise program_error(module, line, f"work object {name} is not declared in the task")


def _speed(
    module: ModuleScope, text: str, options: dict[str, str | None], line: int, state: _State
) -> tuple[float, float]:
    """(v_tcp [m/s], v_ori [rad/s]) of a move's speed argument, \\V and VelSet."""
    key = text.strip()
    if key.casefold() in SPEEDS:
        v_tcp, v_ori = SPEEDS[key.casefold()]
    else:
        value = _numbers(key) if key.startswith("[") else _declared(module, key, "speeddata", line)
        if not (isinstance(value, tuple | list) and len(value) == 4):
            raise program_error(
                module,
                line,
                f"speed {key} is neither a predefined speeddata (v5 .. v7000, vmax) nor a "
                "declared speeddata [v_tcp, v_ori, v_leax, v_reax]",
            )
        v_tcp, v_ori = float(value[0]), float(value[1])
    if "v" in options:
        v_tcp = _number(module, options["v"] or "", line, "the speed \\V")
    v_tcp_m_s = min(v_tcp * state.override, state.v_max_m_s * 1e3) * 1e-3
    v_ori_rad_s = math.radians(v_ori * state.override)
    if not (v_tcp_m_s > 0.0 and v_ori_rad_s > 0.0):
        raise program_error(module, line, f"speed {key} must be positive")
    return v_tcp_m_s, v_ori_rad_s


def _stop_point(module: ModuleScope, text: str, options: dict[str, str | None], line: int) -> bool:
    key = text.strip()
    if "inpos" in options or key.casefold() == "fine":
        return True
    if key.casefold() in ZONES:
        return False
    value = _declared(module, key, "zonedata", line)
    if isinstance(value, tuple) and len(value) == 7 and isinstance(value[0], bool):
        return value[0]
    raise program_error(
        module,
        line,
        f"zone {key} is neither fine, a predefined zone (z0 .. z200) nor a declared zonedata",
    )


def _table(module: ModuleScope, eax_a: float, line: int, state: _State) -> float | None:
    """The table during a move: external axis A [mm -> m], or where it was if unused."""
    if abs(eax_a) >= _UNUSED_AXIS:
        return state.table_m
    position = eax_a * 1e-3
    lo, hi = TABLE_TRAVEL
    if not lo <= position <= hi:
        raise program_error(
            module,
            line,
            f"external axis A at {eax_a:g} mm puts the table outside its travel "
            f"[{lo * 1e3:g}, {hi * 1e3:g}] mm",
        )
    return position


def _target_data(module: ModuleScope, step: Step) -> tuple[Conf, float]:
    """(confdata, eax_a) of a MoveJ / MoveL target: of the robtarget it names (also inside
    Offs / RelTool, which keep them), or of an inline robtarget."""
    assert step.move is not None
    text = step.move.target.strip()
    if text.startswith("["):
        values = _numbers(text)
        if len(values) == 17:  # [[x,y,z],[q1..q4],[cf1,cf4,cf6,cfx],[eax_a..eax_f]]
            return _conf(values[7:11]), values[11]
    base = re.match(r"(?:(?:Offs|RelTool)\s*\(\s*)*([A-Za-z_]\w*)", text, re.I)
    if base is not None:
        for name, target in module.targets.items():
            if name.casefold() == base.group(1).casefold():
                return _conf(target.conf), float(target.eax[0])
    raise program_error(
        module,
        step.line,
        f"{step.instruction} {text}: the target's configuration and external axes are not "
        "known before the program runs (use a robtarget declared at module level)",
    )


def _jointtarget(module: ModuleScope, step: Step, kin: Kinematics) -> tuple[np.ndarray, float]:
    """(q (6,) [rad], eax_a) of a MoveAbsJ's jointtarget, checked against the limits."""
    assert step.move is not None
    text = step.move.target.strip()
    values: list[float] | None = _numbers(text) if text.startswith("[") else None
    if values is None:
        value = _declared(module, text, "jointtarget", step.line)
        if isinstance(value, tuple) and len(value) == 2:
            values = [float(v) for part in value for v in part]
    if values is None or len(values) != 12:
        raise program_error(
            module,
            step.line,
            f"MoveAbsJ {text}: the target must be a declared jointtarget (or an inline one) "
            "[[rax_1, ..., rax_6], [eax_a, ..., eax_f]] in degrees",
        )
    q = np.radians(values[:6])
    bad = np.flatnonzero((q < kin.lower - 1e-9) | (q > kin.upper + 1e-9))
    if bad.size:
        detail = "; ".join(
            f"axis {k + 1} at {values[k]:g} deg outside [{np.degrees(kin.lower[k]):g}, "
            f"{np.degrees(kin.upper[k]):g}]"
            for k in bad
        )
        raise program_error(module, step.line, f"MoveAbsJ {text}: {detail}")
    return q, values[6]


def _conf(values: Sequence[float] | np.ndarray) -> Conf:
    return (int(values[0]), int(values[1]), int(values[2]), int(values[3]))


def _conf_text(conf: Conf) -> str:
    return f"[{','.join(str(c) for c in conf)}]"


def _straight(
    kin: Kinematics, q0: np.ndarray, T_end: np.ndarray, T_tcp: np.ndarray
) -> tuple[np.ndarray | None, float, float]:
    """Follow the straight TCP line from q0 (6,) to T_end (4, 4) with the IK, seeded from the
    previous sample: (q at the end or None, the fraction of the line reached, the residual
    [m] where it failed)."""
    T0 = kin.fk(q0) @ T_tcp
    dist = float(np.linalg.norm(T_end[:3, 3] - T0[:3, 3]))
    R = T0[:3, :3].T @ T_end[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    n = max(8, math.ceil(dist / _LINE_STEP_M), math.ceil(angle / _LINE_STEP_RAD))
    s = np.arange(1, n + 1) / n
    q = np.array(q0, dtype=float)
    for k, T in enumerate(straight_path(T0, T_end, s)):
        r = kin.ik(T, q, T_tcp, extra_seeds=0)
        if not r.success or np.max(np.abs(r.q - q)) > MAX_JOINT_STEP_RAD:
            return None, float(s[k - 1]) if k else 0.0, r.position_error_m
        q = r.q
    return q, 1.0, 0.0


def _speed_fraction(
    kin: Kinematics,
    q0: np.ndarray,
    q1: np.ndarray,
    T_tcp: np.ndarray,
    v_tcp_m_s: float,
    v_ori_rad_s: float,
    joint_speed: np.ndarray,
) -> float:
    """The fraction of the joints' speed limits at which a joint move from q0 to q1 brings
    the TCP's peak speed to v_tcp (and its reorientation to v_ori): with every joint's peak
    speed at f times the limits the slowest joint takes t = max |dq| / speed / f at peak
    speed, and the TCP travels its path of length L (sampled with FK) at about L / t."""
    dq = np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float)
    t_unit = float(np.max(np.abs(dq) / joint_speed))
    if t_unit <= 0.0:
        return 1.0
    points = np.array([(kin.fk(q0 + s * dq) @ T_tcp)[:3, 3] for s in np.linspace(0, 1, 9)])
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    R = (kin.fk(q0) @ T_tcp)[:3, :3].T @ (kin.fk(q1) @ T_tcp)[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    fraction = 1.0
    if length > 1e-9:
        fraction = min(fraction, v_tcp_m_s * t_unit / length)
    if angle > 1e-9:
        fraction = min(fraction, v_ori_rad_s * t_unit / angle)
    return float(np.clip(fraction, _MIN_SPEED_FRACTION, 1.0))


def _instruction(module: ModuleScope, step: Step) -> str:
    """The move's instruction as the executor names it: "MoveJ", "MoveL" or "MoveAbsJ"."""
    kind = step.instruction.casefold()
    if kind not in ("movej", "movel", "moveabsj"):
        raise program_error(
            module,
            step.line,
            f"{step.instruction} is not executed: the cell's controller runs MoveJ, MoveL and "
            "MoveAbsJ (no circular moves, no I/O or synchronisation along a move)",
        )
    return {"movej": "MoveJ", "movel": "MoveL", "moveabsj": "MoveAbsJ"}[kind]


def _move_options(module: ModuleScope, step: Step, instruction: str) -> dict[str, str | None]:
    """The move's optional arguments: name (lower case) -> value as written (None: none);
    refuses those the executor does not take (MOVE_OPTIONS)."""
    assert step.move is not None
    written = [_option(o) for o in step.options]
    unknown = [name for name, _value in written if name.casefold() not in _MOVE_OPTIONS]
    if unknown:
        given = ", ".join(f"\\{u}" for u in unknown)
        taken = ", ".join(f"\\{o}" for o in MOVE_OPTIONS)
        raise program_error(
            module,
            step.line,
            f"{instruction} {step.move.target}: the optional argument(s) {given} are not "
            f"executed (the executor takes {taken})",
        )
    return {name.casefold(): value for name, value in written}


def _move_tool(
    module: ModuleScope, name: str, tools: Mapping[str, np.ndarray], line: int, state: _State
) -> ToolData | None:
    """The move's tooldata `name` (None: tool0), checked to stand for the cell's tool the
    program's earlier moves use (the first one that uses a tool sets it in `state`)."""
    tool = _tooldata(module, name, line)
    if tool is None:
        return None
    cell_tool = _match_tool(module, tool, tools, line)
    if state.cell_tool is not None and cell_tool != state.cell_tool:
        raise program_error(
            module,
            line,
            f"tooldata {tool.name} is the cell's {cell_tool}, but the move at line "
            f"{state.cell_tool_line} uses the {state.cell_tool}: the executor changes the "
            "tool only before the program starts",
        )
    if state.cell_tool is None:
        state.cell_tool, state.cell_tool_line = cell_tool, line
    return tool


def _plan_move(
    module: ModuleScope,
    step: Step,
    kin: Kinematics,
    tools: Mapping[str, np.ndarray],
    joint_speed: np.ndarray,
    state: _State,
    seed: int,
) -> PlannedMove:
    """One move resolved for the nominal arm `kin` from the controller's `state` (updated:
    the joints and the table at its end)."""
    move = step.move
    assert move is not None
    line = step.line
    instruction = _instruction(module, step)
    options = _move_options(module, step, instruction)
    tool = _move_tool(module, move.tool, tools, line, state)
    T_tcp = np.eye(4) if tool is None else tool.T_flange_tcp
    wobj, T_base_oframe = _object_frame(module, move.wobj, line)
    v_tcp, v_ori = _speed(module, move.speed, options, line, state)
    stop = _stop_point(module, move.zone, options, line)
    conf: Conf | None = None
    if instruction == "MoveAbsJ":
        q, eax_a = _jointtarget(module, step, kin)
        T_base_tcp = kin.fk(q) @ T_tcp
    else:
        if move.T_wobj_tcp is None:
            raise program_error(
                module,
                line,
                f"{instruction} {move.target}: the target is known only when the program runs",
            )
        target_conf, eax_a = _target_data(module, step)
        T_base_tcp = T_base_oframe @ move.T_wobj_tcp
        monitored = state.conf_j if instruction == "MoveJ" else state.conf_l
        conf = target_conf if monitored else None
        q = _solve(module, step, kin, T_base_tcp, T_tcp, conf, target_conf, state, seed)
    table = _table(module, eax_a, line, state)
    fraction = 1.0
    if instruction != "MoveL":
        fraction = _speed_fraction(kin, state.q, q, T_tcp, v_tcp, v_ori, joint_speed)
    planned = PlannedMove(
        instruction,
        move.target,
        line,
        step.routine,
        _FLANGE if tool is None else tool.name,
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
    )
    state.q, state.table_m = q, table
    return planned


def _solve(
    module: ModuleScope,
    step: Step,
    kin: Kinematics,
    T_base_tcp: np.ndarray,
    T_tcp: np.ndarray,
    conf: Conf | None,
    target_conf: Conf,
    state: _State,
    seed: int,
) -> np.ndarray:
    """The joints of a MoveJ (in `conf`) or the end of a MoveL (along the line, then checked
    against `conf`); raises RapidError naming the line if the nominal arm cannot."""
    assert step.move is not None
    what = f"{step.instruction} {step.move.target}"
    p = ", ".join(f"{v * 1e3:.1f}" for v in T_base_tcp[:3, 3])
    if step.instruction.casefold() == "movel":
        q, reached, residual = _straight(kin, state.q, T_base_tcp, T_tcp)
        if q is None:
            anywhere = solve_in_configuration(kin, T_base_tcp, T_tcp, None, state.q, seed)
            if not anywhere.reachable:
                raise program_error(
                    module,
                    step.line,
                    f"{what}: the nominal arm cannot reach the target (TCP at [{p}] mm in the "
                    f"base frame; IK residual {anywhere.residual_m * 1e3:.3g} mm)",
                )
            raise program_error(
                module,
                step.line,
                f"{what}: the nominal arm cannot follow the straight line to the target: it "
                f"fails at {reached * 100:.0f}% of the line (residual {residual * 1e3:.3g} mm, "
                "or a configuration flip)",
            )
        if conf is not None and not honours(kin, q, conf):
            raise program_error(
                module,
                step.line,
                f"{what}: the straight line from the previous point ends in configuration "
                f"{_conf_text(configuration(kin, q))}, the robtarget asks for "
                f"{_conf_text(conf)} (ConfL\\On: a controller stops with a configuration "
                "error; program a MoveJ to the target, or ConfL\\Off)",
            )
        return q
    solution = solve_in_configuration(kin, T_base_tcp, T_tcp, conf, state.q, seed)
    if not solution.reachable:
        raise program_error(
            module,
            step.line,
            f"{what}: the nominal arm cannot reach the target (TCP at [{p}] mm in the base "
            f"frame; IK residual {solution.residual_m * 1e3:.3g} mm)",
        )
    if solution.q is None:
        found = ", ".join(_conf_text(c) for c in solution.found)
        raise program_error(
            module,
            step.line,
            f"{what}: the nominal arm has no solution in configuration "
            f"{_conf_text(target_conf)} within its joint limits; its solutions for this pose "
            f"are in {found} (ConfJ\\On: a controller stops here; correct the robtarget's "
            "confdata, or run with ConfJ\\Off to take the nearest solution)",
        )
    return solution.q


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
    state = _State(q=q0)
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
        main.label if len(task.modules) == 1 else task.label,
        main.name,
        _task_compensation(task, main),
        state.cell_tool,
        q0,
        kinematics.fk(q0),
        tuple(moves),
        tuple(skipped),
    )


def _set_state(module: ModuleScope, step: Step, state: _State) -> bool:
    """Apply ConfJ, ConfL or VelSet to `state`; False for any other instruction."""
    name = step.instruction.casefold()
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
        override = _number(module, step.arguments[0], step.line, "the VelSet override")
        v_max = _number(module, step.arguments[1], step.line, "the VelSet maximum speed")
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
        raise program_error(
            module,
            step.line,
            f"unknown instruction {step.instruction!r}: neither a PROC of the task nor a "
            "RAPID instruction; the executor cannot tell whether it moves the arm",
        )


def _task_compensation(task: RapidTask, main: RapidModule) -> str:
    """The compensation the task states: main's module first, then the others in order."""
    for module in (main, *(m for m in task.modules if m is not main)):
        stated = compensation(module)
        if _COMPENSATION.search(module.text):
            return stated
    return "nominal"


# ---------------------------------------------------------------------------------------------
# Execution


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
    controller: Controller, plan: ExecutionPlan, on_move: Callable[[str], None] | None = None
) -> None:
    """What a plan's execution does before its first move: check that the controller is the
    one it was planned for (its tools, its kinematics), change to the plan's tool (through
    home) and joint move to q_start; `on_move(what)` after each motion."""
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
    if plan.tool is not None and controller.tool_in_hand != plan.tool:
        change_tool_safely(controller, plan.tool)
        moved("tool change")
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
    settle = SETTLE_S if move.stop else 0.0
    try:
        table = move.table_position_m
        if table is not None and abs(controller.table_position() - table) > 1e-9:
            controller.move_table(table)
            moved("table")
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
