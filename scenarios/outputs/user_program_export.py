"""A user's own RAPID program written back corrected: its work object's oframe set to the
scan's match and, filtered for the calibrated arm (compensation "filtered"), the robtargets
of its touches and the tooldata of its tool rewritten as scenarios.rapid.writer's `Filter`
has them, so that a controller without absolute accuracy reaches the corrected targets.

Filtering rewrites each touch's approach and touch robtarget: the pose the nominal arm has
at the joints the calibrated arm needs for the corrected target, in the corrected work
object's frame, with the nominal arm's configuration data at those joints; and the tooldata
the touch moves use, with the calibrated TCP (`Filter.T_flange_tcp`). A robtarget used by a
touch and also elsewhere (another move, an Offs) is rewritten all the same: every use of it
then gets the filtered pose. A robtarget two touches share takes the first one's. Everything
else of the module is kept byte for byte, and a task's modules that declare none of the
rewritten data (nor the work object) are kept as they were.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import Kinematics, nominal_kinematics
from scenarios.offline.operations import UserProgram
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.module import RapidModule
from scenarios.rapid.oframe import with_oframe
from scenarios.rapid.rapid_text import configuration
from scenarios.rapid.robtarget_rewrite import TargetRewrite, with_rewritten
from scenarios.rapid.touches import folded
from scenarios.rapid.writer import Filter


@dataclass(frozen=True, eq=False)
class WrittenBack:
    """The user's program written back: each readable module of its task (in the task's
    order) with its text, and the robtargets and tooldata rewritten (names as written in
    the moves; empty for compensation "nominal")."""

    texts: tuple[tuple[RapidModule, str], ...]
    targets: tuple[str, ...]
    tools: tuple[str, ...]


def _modules(user: UserProgram) -> tuple[RapidModule, ...]:
    return user.task.modules if user.task is not None else (user.wobj_module or user.module,)


def _holder(user: UserProgram, name: str, datatype: str) -> RapidModule | None:
    """The module whose module-level `datatype` `name` the touch module sees: its own, else
    the last other module of the task declaring it global (as the task's scope has it)."""

    def declares(module: RapidModule, own: bool) -> bool:
        decl = next((d for n, d in module.data.items() if folded(n) == folded(name)), None)
        return (
            decl is not None
            and decl.datatype.casefold() == datatype
            and (own or decl.scope.upper() != "LOCAL")
        )

    modules = _modules(user)
    own = next((m for m in modules if m.name == user.module.name), None)
    if own is not None and declares(own, True):
        return own
    others = [m for m in modules if m is not own and declares(m, False)]
    return others[-1] if others else None


def _touch_names(user: UserProgram) -> tuple[str, ...]:
    """The touches' approach and touch targets as written, each once, in the order of the
    operations."""
    names: dict[str, str] = {}
    for op in user.operations:
        names.setdefault(folded(op.approach), op.approach)
        names.setdefault(folded(op.name), op.name)
    return tuple(names.values())


def _touch_tools(user: UserProgram) -> tuple[str, ...]:
    """The tooldata the moves to the touches' targets use, each once (tool0 left out)."""
    targets = {folded(n) for n in _touch_names(user)}
    wobj = user.wobj.name.casefold()
    tools: dict[str, str] = {}
    for move in user.module.moves:
        mine = move.wobj is not None and move.wobj.casefold() == wobj
        if mine and folded(move.target) in targets and move.tool.casefold() != "tool0":
            tools.setdefault(move.tool.casefold(), move.tool)
    return tuple(tools.values())


def filter_refusal(user: UserProgram) -> str | None:
    """Why the user's program cannot be written back filtered, or None: each touch's approach
    and touch must be a robtarget with a value declared in a readable module of the task (not
    an expression such as Offs(p10,0,0,50), nor data of an encrypted module), and so must the
    tooldata of the moves to them."""
    for name in _touch_names(user):
        if folded(name) not in {folded(n) for n in user.module.targets}:
            return f"the touch target {name} is no robtarget declared in the program"
    for tool in _touch_tools(user):
        if _holder(user, tool, "tooldata") is None:
            return f"the tooldata {tool} is not declared in a readable module"
    return None


def _rewrites(
    user: UserProgram, program: OfflineProgram, filtered: Filter, nominal: Kinematics,
    T_base_wobj: np.ndarray,
) -> dict[str, tuple[str, TargetRewrite]]:  # fmt: skip
    """The touches' robtargets filtered: folded name -> (name as written, new value)."""
    to_wobj = np.linalg.inv(T_base_wobj)
    T_tcp = filtered.T_flange_tcp(program.tool)
    rewrites: dict[str, tuple[str, TargetRewrite]] = {}
    solved = filtered.targets(program, T_tcp)
    for op, (T_app, q_app, T_touch, q_touch) in zip(user.operations, solved, strict=True):
        for name, T, q in ((op.approach, T_app, q_app), (op.name, T_touch, q_touch)):
            rewrite = TargetRewrite(to_wobj @ T, configuration(nominal, q))
            rewrites.setdefault(folded(name), (name, rewrite))
    return rewrites


def written_back(
    user: UserProgram,
    program: OfflineProgram,
    filtered: Filter | None = None,
    nominal: Kinematics | None = None,
) -> WrittenBack:
    """The user's program with its work object's oframe corrected to the program's object
    pose (`program.T_base_object`), and with `filtered` its touches' robtargets (configuration
    data from the `nominal` arm, default the built-in arm's) and tooldata filtered (see the
    module's docstring; `filter_refusal` must have found nothing to refuse)."""
    T_uframe_oframe = np.linalg.inv(user.wobj.T_base_uframe) @ program.T_base_object
    declaring = user.wobj_module or user.module
    edits: dict[int, tuple[dict[str, TargetRewrite], dict[str, np.ndarray]]] = {}
    targets: tuple[str, ...] = ()
    tools = _touch_tools(user) if filtered is not None else ()
    if filtered is not None:
        kin = nominal_kinematics() if nominal is None else nominal
        T_base_wobj = user.wobj.T_base_uframe @ T_uframe_oframe
        rewrites = _rewrites(user, program, filtered, kin, T_base_wobj)
        for name, rewrite in rewrites.values():
            holder = _holder(user, name, "robtarget")
            assert holder is not None  # filter_refusal checked it
            edits.setdefault(id(holder), ({}, {}))[0][name] = rewrite
        T_flange_tcp = filtered.T_flange_tcp(program.tool)
        for tool in tools:
            holder = _holder(user, tool, "tooldata")
            assert holder is not None
            edits.setdefault(id(holder), ({}, {}))[1][tool] = T_flange_tcp
        targets = tuple(name for name, _ in rewrites.values())
    texts = []
    for module in _modules(user):
        text = module.text
        if module is declaring:
            text = with_oframe(declaring, user.wobj.name, T_uframe_oframe)
        if id(module) in edits:
            text = with_rewritten(text, module.label, *edits[id(module)])
        texts.append((module, text))
    return WrittenBack(tuple(texts), targets, tools)
