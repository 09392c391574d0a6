"""An ABB RAPID module's model, as scenarios.rapid.reader reads it: its tools, work objects
and robtargets declared at module level, its moves, every module-level declaration, its
routines and instruction statements; and `with_value`, its text with one datum's value
rewritten (the served controller's symbol writes).

RAPID is in millimetres and scalar-first quaternions [q1 = w, q2, q3, q4]; everything read is
converted at the reader to metres and 4 x 4 homogeneous transforms. A robtarget is the TCP
pose in its work object's object frame, so the controller moves the TCP to
uframe @ oframe @ robtarget.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenarios.rapid.parser import Parser
from scenarios.rapid.syntax import RapidError, Routine, location

# Moves whose leading arguments are: target(s), speed, zone, tool [\WObj]: name -> targets.
MOVES = {
    "movej": 1,
    "movel": 1,
    "movec": 2,
    "moveabsj": 1,
    "movejdo": 1,
    "moveldo": 1,
    "movecdo": 2,
    "movejsync": 1,
    "movelsync": 1,
    "movecsync": 2,
}


# ---------------------------------------------------------------------------------------------
# Results


@dataclass(frozen=True, eq=False)
class ToolData:
    """A `tooldata`: held by the robot (`robhold`), the TCP frame in the flange frame
    T_flange_tcp (4, 4) [m] (for a stationary tool, robhold False: in the world frame), the
    load's mass [kg] and centre of gravity cog_m (3,) [m, flange frame]."""

    name: str
    robhold: bool
    T_flange_tcp: np.ndarray
    mass_kg: float
    cog_m: np.ndarray
    line: int


@dataclass(frozen=True, eq=False)
class WobjData:
    """A `wobjdata`: held by the robot (`robhold`), fixed or programmed user frame (`ufprog`),
    the mechanical unit moving it (`ufmec`, "" if none), the user frame in the world (or base)
    frame T_base_uframe (4, 4) [m] and the object frame in the user frame T_uframe_oframe
    (4, 4) [m]."""

    name: str
    robhold: bool
    ufprog: bool
    ufmec: str
    T_base_uframe: np.ndarray
    T_uframe_oframe: np.ndarray
    line: int


@dataclass(frozen=True, eq=False)
class RobTarget:
    """A `robtarget`: the TCP pose in the object frame of the work object it is used with,
    T_wobj_tcp (4, 4) [m] (that frame is uframe @ oframe), the configuration (cf1, cf4, cf6,
    cfx) conf (4,) ints and the external axes eax (6,) as written [mm or deg; 9E+09 unused]."""

    name: str
    T_wobj_tcp: np.ndarray
    conf: np.ndarray
    eax: np.ndarray
    line: int


@dataclass(frozen=True, eq=False)
class Move:
    """A move instruction: the target as written (a name or an expression), its TCP pose in
    the work object's object frame T_wobj_tcp (4, 4) [m] with Offs / RelTool evaluated (None
    for MoveAbsJ and for a target known only at run time), the speed, zone and tool as
    written, the work object (None: wobj0), the line, the routine, the optional arguments as
    written (\\Conc, \\V:=..., \\WObj:=...), and for MoveC the circle point."""

    instruction: str
    target: str
    T_wobj_tcp: np.ndarray | None
    speed: str
    zone: str
    tool: str
    wobj: str | None
    line: int
    routine: str = ""
    options: tuple[str, ...] = ()
    circle_point: str | None = None
    T_wobj_circle_point: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Declaration:
    """A module-level data declaration: storage class (PERS, CONST, VAR), scope (LOCAL, TASK
    or ""), the value as literal Python values (numbers as float, TRUE/FALSE as bool, strings,
    aggregates as tuples; None when absent or not a literal) and as written."""

    name: str
    datatype: str
    storage: str
    scope: str
    value: object
    text: str | None
    line: int


@dataclass(frozen=True)
class Instruction:
    """An instruction statement as written (a move, a RAPID instruction or a call of a
    procedure): its name, its line, the routine it is in."""

    name: str
    line: int
    routine: str


@dataclass(frozen=True, eq=False)
class RapidModule:
    """A RAPID module as read: its name, its text (unchanged), the tools, work objects and
    robtargets declared at module level (by name as declared), the moves of all its routines
    in the order of the text, the file it was read from, and every module-level declaration;
    its routines, every instruction statement (moves, RAPID instructions and calls, in the
    order of the text), the data types it declares (RECORD and ALIAS names), its attributes
    (MODULE_ATTRIBUTES, upper case), the `%%%` header's fields (e.g. ("VERSION", "1"),
    ("LANGUAGE", "ENGLISH")) and its placeholders with their lines (e.g. ("<SMT>", 12): what
    the program editor marks as not written yet; a placeholder statement is an instruction
    named so)."""

    name: str
    text: str
    tools: dict[str, ToolData]
    wobjs: dict[str, WobjData]
    targets: dict[str, RobTarget]
    moves: tuple[Move, ...]
    path: Path | None
    data: dict[str, Declaration] = field(default_factory=dict)
    routines: tuple[Routine, ...] = ()
    instructions: tuple[Instruction, ...] = ()
    records: tuple[str, ...] = ()
    attributes: tuple[str, ...] = ()
    header: tuple[tuple[str, str], ...] = ()
    placeholders: tuple[tuple[str, int], ...] = ()

    @property
    def label(self) -> str:
        """What messages call the module: its file, else "module <name>"."""
        return str(self.path) if self.path is not None else f"module {self.name}"


def find_wobj(module: RapidModule, wobj: str) -> WobjData:
    """The module's wobjdata named `wobj` (any case); raises RapidError naming those declared
    if it has none."""
    for name, data in module.wobjs.items():
        if name.casefold() == wobj.casefold():
            return data
    declared = ", ".join(module.wobjs) or "none"
    raise RapidError(f"{module.label}: no wobjdata {wobj!r} is declared (declared: {declared})")


def with_value(module: RapidModule, name: str, value: str) -> str:
    """The module's text with the value of its module-level datum `name` (as declared, any
    case) written as `value` (RAPID text, e.g. "3.5" or "[[600,0,800],[1,0,0,0],...]"):
    the old initializer replaced, or `:= value` added to a declaration that has none. Every
    other character is kept. Raises RapidError if the module declares no such datum; the
    caller reads the result again to check that the value is what the type needs."""
    parser = Parser(module.text, module.label)
    parser.module()
    decl = next(
        (d for d in parser.decls if d.routine is None and d.name.casefold() == name.casefold()),
        None,
    )
    if decl is None:
        raise RapidError(f"{module.label}: no module-level datum {name!r} is declared")
    text = module.text
    if decl.value is not None:
        return text[: decl.value.start] + value + text[decl.value.end :]
    lines = text.splitlines(keepends=True)
    pattern = re.compile(rf"(\b{re.escape(decl.name)}\s*(?:\{{[^}}]*\}})?)\s*;", re.I)
    line = lines[decl.line - 1]
    found = pattern.search(line)
    if found is None:
        raise RapidError(
            f"{location(module.label, decl.line)}: the declaration of {decl.name} spans lines; "
            "give it an initial value in the module"
        )
    written = f"{found.group(1)} := {value};"
    lines[decl.line - 1] = line[: found.start()] + written + line[found.end() :]
    return "".join(lines)
