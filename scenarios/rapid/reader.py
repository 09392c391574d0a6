"""The RAPID reader: a module's syntax (scenarios.rapid.parser) built into its typed model
(scenarios.rapid.module) with its names and values resolved, in its own module and then in
the data the other modules of its task make visible to it.

RAPID is in millimetres and scalar-first quaternions [q1 = w, q2, q3, q4]; everything read is
converted here to metres and 4 x 4 homogeneous transforms. The reader does not run the
program: data are taken at their declared values, and a target that depends on run-time
values (a routine parameter, a FOR variable, a function such as CRobT) is kept with no pose.
"""

from __future__ import annotations

import operator
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.rapid.module import (
    MOVES,
    Declaration,
    Instruction,
    Move,
    RapidModule,
    RobTarget,
    ToolData,
    WobjData,
)
from scenarios.rapid.parser import parse_module
from scenarios.rapid.syntax import (
    Arg,
    Call,
    Decl,
    ModuleText,
    Node,
    ParsedModule,
    RapidError,
    as_float,
    location,
)

# Data every controller declares in its BASE module.
_PREDEFINED = {"tool0": "tooldata", "wobj0": "wobjdata", "load0": "loaddata"}

_QUATERNION_NORM_TOLERANCE = 1e-3


# ---------------------------------------------------------------------------------------------
# Values: literals, poses


#: RAPID's predefined constants of type stoppoint (a stoppointdata's first component).
STOPPOINT_TYPES = {"inpos": 1.0, "stoptime": 2.0, "fllwtime": 3.0}


def _literal(node: Node | None) -> object:
    """The Python value of a literal (float, bool, str, nested tuples; a stoppoint constant
    as its number), None if not one."""
    if node is None:
        return None
    if node.kind in ("num", "str", "bool"):
        return node.value
    if node.kind == "name" and str(node.value).casefold() in STOPPOINT_TYPES:
        return STOPPOINT_TYPES[str(node.value).casefold()]
    if node.kind == "unary" and node.value in ("-", "+") and node.items[0].kind == "num":
        value = as_float(node.items[0].value)
        return -value if node.value == "-" else value
    if node.kind == "agg":
        items = tuple(_literal(item) for item in node.items)
        return None if any(item is None for item in items) else items
    return None


def _numbers(value: object, n: int) -> np.ndarray | None:
    if isinstance(value, tuple) and len(value) == n and all(isinstance(v, float) for v in value):
        return np.array(value, dtype=float)
    return None


def _R_from_quaternion(q: np.ndarray, what: str, where: str) -> np.ndarray:
    """(3, 3) rotation of a scalar-first quaternion [q1 = w, q2, q3, q4], normalised."""
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > _QUATERNION_NORM_TOLERANCE:
        raise RapidError(
            f"{where}: the quaternion [{','.join(f'{v:g}' for v in q)}] of {what} has norm "
            f"{norm:.6g}; RAPID needs a unit quaternion (within {_QUATERNION_NORM_TOLERANCE:g})"
        )
    return Rotation.from_quat(q / norm, scalar_first=True).as_matrix()


def _pose(value: object, what: str, where: str) -> np.ndarray:
    """(4, 4) [m] of a RAPID pose [[x, y, z], [q1, q2, q3, q4]] in mm."""
    if isinstance(value, tuple) and len(value) == 2:
        p, q = _numbers(value[0], 3), _numbers(value[1], 4)
        if p is not None and q is not None:
            T = np.eye(4)
            T[:3, :3] = _R_from_quaternion(q, what, where)
            T[:3, 3] = p * 1e-3
            return T
    raise RapidError(f"{where}: {what} must be a pose [[x,y,z],[q1,q2,q3,q4]]")


def _bool(value: object, what: str, where: str) -> bool:
    if not isinstance(value, bool):
        raise RapidError(f"{where}: {what} must be TRUE or FALSE")
    return value


def _tool(name: str, value: object, where: str, line: int) -> ToolData:
    if not (isinstance(value, tuple) and len(value) == 3):
        raise RapidError(f"{where}: tooldata {name} must be [robhold, tframe, tload]")
    load = value[2]
    mass = load[0] if isinstance(load, tuple) and len(load) == 6 else None
    cog = _numbers(load[1], 3) if isinstance(load, tuple) and len(load) == 6 else None
    if not isinstance(mass, float) or cog is None:
        raise RapidError(
            f"{where}: the tload of tooldata {name} must be [mass, [x,y,z], [q1,q2,q3,q4], "
            "ix, iy, iz]"
        )
    return ToolData(
        name,
        _bool(value[0], f"the robhold of tooldata {name}", where),
        _pose(value[1], f"the tframe of tooldata {name}", where),
        mass,
        cog * 1e-3,
        line,
    )


def _wobj(name: str, value: object, where: str, line: int) -> WobjData:
    if not (isinstance(value, tuple) and len(value) == 5 and isinstance(value[2], str)):
        raise RapidError(
            f"{where}: wobjdata {name} must be [robhold, ufprog, ufmec, uframe, oframe]"
        )
    return WobjData(
        name,
        _bool(value[0], f"the robhold of wobjdata {name}", where),
        _bool(value[1], f"the ufprog of wobjdata {name}", where),
        value[2],
        _pose(value[3], f"the uframe of wobjdata {name}", where),
        _pose(value[4], f"the oframe of wobjdata {name}", where),
        line,
    )


def _robtarget(name: str, value: object, where: str, line: int) -> RobTarget:
    if isinstance(value, tuple) and len(value) == 4:
        conf, eax = _numbers(value[2], 4), _numbers(value[3], 6)
        if conf is not None and eax is not None and np.all(conf == np.round(conf)):
            T = _pose(value[:2], f"robtarget {name}", where)
            return RobTarget(name, T, conf.astype(int), eax, line)
    raise RapidError(
        f"{where}: robtarget {name} must be "
        "[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,eax_b,eax_c,eax_d,eax_e,eax_f]] "
        "with integer configuration"
    )


def _translation(d_m: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = d_m
    return T


def _rotation(axis: str, angle_deg: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler(axis, angle_deg, degrees=True).as_matrix()
    return T


# ---------------------------------------------------------------------------------------------
# From the syntax tree to the typed module


@dataclass(frozen=True)
class _Scope:
    routine: str
    loop_vars: frozenset[str]


_ARITHMETIC = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}
_RUNTIME = "run-time"  # a name bound only when the program runs (parameter, FOR variable)
#: A name declared in none of the task's readable modules, where the task holds encrypted ones
#: that may declare it: known only when the program runs.
_UNKNOWN = "unknown"
_UNRESOLVED = (_RUNTIME, _UNKNOWN)


class _Builder:
    def __init__(
        self,
        parsed: ParsedModule,
        text: str,
        source: str | None,
        outer: dict[str, Decl],
        opaque: bool = False,
    ) -> None:
        self.text = text
        self.opaque = opaque
        self.source = source
        self.params = parsed.params
        self.outer = outer
        self.module_decls: dict[str, Decl] = {}
        self.local_decls: dict[tuple[str, str], Decl] = {}
        for decl in parsed.decls:
            key = decl.name.casefold()
            if decl.routine is not None:
                self.local_decls[(decl.routine.casefold(), key)] = decl
            elif key in self.module_decls:
                first = self.module_decls[key].line
                raise self.error(decl.line, f"{decl.name} is declared twice (also at line {first})")
            else:
                self.module_decls[key] = decl
        self.targets: dict[str, RobTarget] = {}
        self.tools: dict[str, ToolData] = {}
        self.wobjs: dict[str, WobjData] = {}
        for decl in self.module_decls.values():
            value = _literal(decl.value)
            if decl.array or value is None:
                continue
            where = location(source, decl.line)
            kind = decl.datatype.casefold()
            if kind == "robtarget":
                self.targets[decl.name] = _robtarget(decl.name, value, where, decl.line)
            elif kind == "tooldata":
                self.tools[decl.name] = _tool(decl.name, value, where, decl.line)
            elif kind == "wobjdata":
                self.wobjs[decl.name] = _wobj(decl.name, value, where, decl.line)

    def error(self, line: int, message: str) -> RapidError:
        return RapidError(f"{location(self.source, line)}: {message}")

    def lookup(self, name: str, scope: _Scope) -> Decl | str | None:
        """The declaration of a plain name seen from `scope`: _RUNTIME for a parameter or a
        FOR variable, the predefined data type for tool0 / wobj0 / load0, None if undeclared
        (_UNKNOWN where the task's encrypted modules may declare it)."""
        key = name.casefold()
        if key in scope.loop_vars or key in self.params.get(scope.routine.casefold(), ()):
            return _RUNTIME
        decl = (
            self.local_decls.get((scope.routine.casefold(), key))
            or self.module_decls.get(key)
            or self.outer.get(key)
        )
        if decl is not None:
            return decl
        return _PREDEFINED.get(key, _UNKNOWN if self.opaque else None)

    def check_declared(self, node: Node, datatype: str, role: str, call: Call) -> None:
        """A name used as `role` (a tooldata, wobjdata, jointtarget) must be declared as one."""
        if node.kind != "name":
            return
        base = re.match(r"[A-Za-z_]\w*", str(node.value))
        assert base is not None
        found = self.lookup(base.group(), _Scope(call.routine, call.loop_vars))
        if found is None:
            raise self.error(node.line, f"the {role} {base.group()} of {call.name} is not declared")
        kind = found.datatype if isinstance(found, Decl) else found
        if found not in _UNRESOLVED and kind.casefold() != datatype and base.group() == node.value:
            raise self.error(
                node.line, f"the {role} {node.value} of {call.name} is a {kind}, not a {datatype}"
            )

    def number(self, node: Node, scope: _Scope, call: Call) -> float | None:
        """A numeric argument [as written], None if known only at run time."""
        if node.kind == "num":
            return as_float(node.value)
        if node.kind == "unary" and node.value in ("-", "+"):
            x = self.number(node.items[0], scope, call)
            return None if x is None else (-x if node.value == "-" else x)
        if node.kind == "binary" and node.value in _ARITHMETIC:
            a, b = (self.number(item, scope, call) for item in node.items)
            if a is None or b is None or (node.value == "/" and b == 0.0):
                return None
            return _ARITHMETIC[str(node.value)](a, b)
        if node.kind == "name" and re.fullmatch(r"[A-Za-z_]\w*", str(node.value)):
            found = self.lookup(str(node.value), scope)
            if found is None:
                raise self.error(node.line, f"{node.value} in {call.name} is not declared")
            if isinstance(found, Decl) and found.datatype.casefold() == "num":
                value = _literal(found.value)
                return value if isinstance(value, float) else None
            if found in _UNRESOLVED:
                return None
            kind = found.datatype if isinstance(found, Decl) else found
            raise self.error(node.line, f"{node.value} in {call.name} is a {kind}, not a num")
        return None

    def target_pose(self, node: Node, scope: _Scope, call: Call) -> np.ndarray | None:
        """T_wobj_tcp (4, 4) [m] of a move's target: a robtarget's name, an inline robtarget,
        Offs(...) or RelTool(...); None if known only at run time."""
        if node.kind == "agg":
            value = _literal(node)
            if value is None:
                return None
            where = location(self.source, node.line)
            return _robtarget("(inline)", value, where, node.line).T_wobj_tcp
        if node.kind == "name":
            return self.named_pose(node, scope, call)
        if node.kind == "call" and str(node.value).casefold() in ("offs", "reltool"):
            return self.offset_pose(node, scope, call)
        if node.kind in ("call", "placeholder"):
            return None  # a function known at run time (CRobT, ...), or not written yet
        raise self.error(node.line, f"cannot read the target of {call.name}: {self.slice(node)}")

    def named_pose(self, node: Node, scope: _Scope, call: Call) -> np.ndarray | None:
        """T_wobj_tcp (4, 4) [m] of a robtarget named in a move (declared in the module or in
        the routine); None for a parameter, an array element or a field."""
        self.check_declared(node, "robtarget", "target", call)
        found = self.lookup(str(node.value), scope)  # None: an element or a field
        if not isinstance(found, Decl) or found.array:
            return None
        if found.routine is None and self.module_decls.get(found.name.casefold()) is found:
            target = self.targets.get(found.name)
            return None if target is None else target.T_wobj_tcp.copy()
        value = _literal(found.value)  # declared in the routine, or in another module
        if value is None:
            return None
        where = location(self.source, node.line)
        return _robtarget(found.name, value, where, node.line).T_wobj_tcp

    def offset_pose(self, node: Node, scope: _Scope, call: Call) -> np.ndarray | None:
        """T_wobj_tcp (4, 4) [m] of Offs(target, x, y, z) or RelTool(target, x, y, z [\\Rx]
        [\\Ry] [\\Rz]) (distances [mm], angles [deg]); None if known only at run time."""
        function = str(node.value)
        positional = [a.value for a in node.args if not a.optional and a.value is not None]
        if len(positional) != 4:
            raise self.error(node.line, f"{function} needs a target and three distances")
        T_p = self.target_pose(positional[0], scope, call)
        d = [self.number(arg, scope, call) for arg in positional[1:]]
        angles = {
            a.name.casefold(): self.number(a.value, scope, call)
            for a in node.args
            if a.optional and a.name and a.value is not None
        }
        if T_p is None or any(x is None for x in d + list(angles.values())):
            return None
        d_m = np.array(d, dtype=float) * 1e-3
        if function.casefold() == "offs":
            # Offs: the displacement is along the work object's axes; orientation kept.
            T_p[:3, 3] += d_m
            return T_p
        # RelTool: translation along the target's own (tool) axes first, then rotations
        # about the tool's x, then the new y, then the new z axis (ABB's RelTool
        # reference; RoboDK's robomath.RelTool, written to match it, computes
        # pose * transl(x, y, z) * rotx(rx) * roty(ry) * rotz(rz)).
        T = T_p @ _translation(d_m)
        for axis in ("x", "y", "z"):
            T = T @ _rotation(axis, angles.get(f"r{axis}") or 0.0)
        return T

    def slice(self, item: Node | Arg) -> str:
        return self.text[item.start : item.end]

    def move(self, call: Call) -> Move:
        n_targets = MOVES[call.name.casefold()]
        positional = [a.value for a in call.args if not a.optional and a.value is not None]
        if len(positional) < n_targets + 3:
            needs = "circle point, target" if n_targets == 2 else "target"
            raise self.error(
                call.line,
                f"{call.name} needs {needs}, speed, zone and tool (found "
                f"{len(positional)} arguments)",
            )
        scope = _Scope(call.routine, call.loop_vars)
        *targets, speed, zone, tool = positional[: n_targets + 3]
        self.check_declared(tool, "tooldata", "tool", call)
        wobj = next(
            (a for a in call.args if a.optional and (a.name or "").casefold() == "wobj"), None
        )
        if wobj is not None:
            if wobj.value is None:
                raise self.error(call.line, f"\\WObj of {call.name} needs := and a work object")
            self.check_declared(wobj.value, "wobjdata", "work object", call)
        if call.name.casefold() == "moveabsj":
            self.check_declared(targets[0], "jointtarget", "target", call)
            poses: list[np.ndarray | None] = [None]
        else:
            poses = [self.target_pose(t, scope, call) for t in targets]
        return Move(
            call.name,
            self.slice(targets[-1]),
            poses[-1],
            self.slice(speed),
            self.slice(zone),
            self.slice(tool),
            None if wobj is None or wobj.value is None else self.slice(wobj.value),
            call.line,
            call.routine,
            tuple(self.slice(a) for a in call.args if a.optional),
            self.slice(targets[0]) if n_targets == 2 else None,
            poses[0] if n_targets == 2 else None,
        )

    def declaration(self, decl: Decl) -> Declaration:
        text = None if decl.value is None else self.slice(decl.value)
        return Declaration(
            decl.name,
            decl.datatype,
            decl.storage,
            decl.scope,
            _literal(decl.value),
            text,
            decl.line,
        )


def build_module(
    source: ModuleText, outer: dict[str, Decl] | None = None, opaque: bool = False
) -> RapidModule:
    """The typed module of a parsed text, its names resolved in its own module and then in
    `outer` (the data other modules of its task make visible to it, by case-folded name).
    Raises RapidError naming the file and line for a move whose target, tool or work object
    is declared nowhere, or data that are not what their type needs. With `opaque` (the task
    holds encrypted modules, whose data no reader sees) a name declared nowhere readable is
    left to the run, where a move that needs it is refused at its line."""
    parsed, text, label = source.parsed, source.text, source.label
    builder = _Builder(parsed, text, label, outer or {}, opaque)
    moves = tuple(builder.move(c) for c in parsed.calls if c.name.casefold() in MOVES)
    return RapidModule(
        parsed.name,
        text,
        builder.tools,
        builder.wobjs,
        builder.targets,
        moves,
        source.path,
        {d.name: builder.declaration(d) for d in builder.module_decls.values()},
        tuple(parsed.routines),
        tuple(Instruction(c.name, c.line, c.routine) for c in parsed.calls),
        tuple(parsed.records),
        parsed.attributes,
        parsed.header,
        tuple(parsed.placeholders),
    )


def read_module(source: str | Path, name: str | None = None) -> RapidModule:
    """Read one RAPID module: `source` is its text (str) or its file (Path); `name` is what
    error messages call it (default: the file's path). Every instruction is read whatever its
    name (scenarios.rapid.task names the procedures defined nowhere). Raises RapidError on a
    syntax error, an encrypted or binary file, a move whose target, tool or work object is
    not declared in the module, or data that are not what their type needs (e.g. a
    quaternion off unit length by more than 1e-3). A task of several modules:
    scenarios.rapid.task.read_task."""
    return build_module(parse_module(source, name))
