"""A RAPID move's data resolved for the planner (scenarios.rapid.planner), before anything
moves: its instruction and optional arguments, its tool (a declared tooldata standing for a
tool of the cell, or tool0, the flange), its work object (a declared wobjdata with a fixed user
frame, or wobj0, the base frame), its speed (speeddata v_tcp [mm/s] and v_ori [deg/s],
predefined or declared, \\V:=, VelSet), its zone (fine or \\Inpos: a stop point; zNN: a
fly-by point), its target's confdata, a MoveAbsJ's jointtarget, and the table (external axis A
[mm]; 9E+09 leaves it where it is); and what the controller carries from one instruction to
the next (`PlanState`). A RapidError `<file>:<line>: <what>` names a move that cannot run.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from cell import Kinematics
from models.robot import TABLE_TRAVEL
from scenarios.rapid.confdata import Conf
from scenarios.rapid.flow import Step, program_error
from scenarios.rapid.module import ToolData
from scenarios.rapid.rapid_text import rapid_identifier
from scenarios.rapid.task import ModuleScope

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
_UNUSED_AXIS = 8.9e9
#: The flange's tooldata (a move with it moves the flange).
FLANGE = "tool0"
_BASE = "wobj0"


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


def num_value(module: ModuleScope, text: str, line: int, what: str) -> float:
    """A num argument: a literal or a num declared with a literal value."""
    if re.fullmatch(_NUMBER, text.strip()):
        return float(text)
    value = _declared(module, text.strip(), "num", line)
    if isinstance(value, float):
        return value
    raise program_error(module, line, f"{what} {text!r} is neither a number nor a declared num")


@dataclass
class PlanState:
    """What the controller carries from one instruction to the next."""

    q: np.ndarray
    table_m: float | None = None
    conf_j: bool = True
    conf_l: bool = True
    override: float = 1.0
    v_max_m_s: float = math.inf
    supervised: bool = True
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
    if name.casefold() == FLANGE:
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
    raise program_error(module, line, module.undeclared(f"tooldata {name}"))


def object_frame(module: ModuleScope, name: str | None, line: int) -> tuple[str, np.ndarray]:
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
    raise program_error(module, line, module.undeclared(f"work object {name}"))


def move_speed(
    module: ModuleScope, text: str, options: dict[str, str | None], line: int, state: PlanState
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
        v_tcp = num_value(module, options["v"] or "", line, "the speed \\V")
    v_tcp_m_s = min(v_tcp * state.override, state.v_max_m_s * 1e3) * 1e-3
    v_ori_rad_s = math.radians(v_ori * state.override)
    if not (v_tcp_m_s > 0.0 and v_ori_rad_s > 0.0):
        raise program_error(module, line, f"speed {key} must be positive")
    return v_tcp_m_s, v_ori_rad_s


def stop_point(module: ModuleScope, text: str, options: dict[str, str | None], line: int) -> bool:
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


#: RAPID's predefined stoppointdata of type stoptime: the time the arm stands still [s].
STOP_TIMES = {"stoptime0_5": 0.5, "stoptime1_0": 1.0, "stoptime1_5": 1.5}
_STOPTIME = 2.0  # the stoppoint constant stoptime (scenarios.rapid.reader.STOPPOINT_TYPES)


def stop_time(module: ModuleScope, options: dict[str, str | None], line: int) -> float | None:
    """How long the arm stands still at a stop point whose \\Inpos names a stoppointdata of
    type stoptime [s]; None where the controller settles as at `fine` (no \\Inpos, or one of
    type inpos or fllwtime)."""
    key = (options.get("inpos") or "").strip()
    if not key:
        return None
    if key.casefold() in STOP_TIMES:
        return STOP_TIMES[key.casefold()]
    if re.fullmatch(r"(?i)inpos\d+|fllwtime\d_\d", key):
        return None
    value = _declared(module, key, "stoppointdata", line)
    if not (isinstance(value, tuple) and len(value) == 8 and isinstance(value[3], float)):
        raise program_error(
            module,
            line,
            f"\\Inpos:={key} is neither a predefined stoppointdata (inpos20 .. inpos100, "
            "stoptime0_5 .. stoptime1_5, fllwtime0_5 .. fllwtime1_5) nor a declared "
            "stoppointdata [type, progsynch, inpos, stoptime, followtime, signal, relation, "
            "checkvalue]",
        )
    if value[0] != _STOPTIME:
        return None
    if not (math.isfinite(value[3]) and value[3] >= 0.0):
        raise program_error(module, line, f"the stoptime of {key} must be >= 0 s")
    return value[3]


def table_position(module: ModuleScope, eax_a: float, line: int, state: PlanState) -> float | None:
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


def target_data(module: ModuleScope, step: Step) -> tuple[Conf, float]:
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


def jointtarget(module: ModuleScope, step: Step, kin: Kinematics) -> tuple[np.ndarray, float]:
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


def move_instruction(module: ModuleScope, step: Step) -> str:
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


def move_options(module: ModuleScope, step: Step, instruction: str) -> dict[str, str | None]:
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


def move_tool(
    module: ModuleScope, name: str, tools: Mapping[str, np.ndarray], line: int, state: PlanState
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
