"""A RAPID module's text with some robtargets' poses and configuration data and some tooldata's
TCP frames rewritten, every other character kept (the filtered export of a user's module).

A robtarget [trans, rot, robconf, extax] gets a new trans and rot (the TCP pose in its work
object's object frame, as scenarios.rapid.oframe writes poses: mm to 4 decimals, a
scalar-first quaternion to 8) and a new robconf; its external axes are kept as written. A
tooldata [robhold, tframe, tload] gets a new tframe; the load is kept. Each aggregate keeps
the separator it was written with (", " or ",").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from scenarios.rapid.oframe import orientation_text, pose_text, position_text, separator_of
from scenarios.rapid.parser import Parser
from scenarios.rapid.syntax import Decl, Node, RapidError, location


@dataclass(frozen=True, eq=False)
class TargetRewrite:
    """A robtarget's new value: the TCP pose in its work object's object frame T_wobj_tcp
    (4, 4) [m] and the configuration data (cf1, cf4, cf6, cfx)."""

    T_wobj_tcp: np.ndarray
    conf: tuple[int, int, int, int]


def _declaration(decls: dict[str, Decl], name: str, datatype: str, label: str) -> Decl:
    """The module-level declaration of `datatype` `name` (any case) with a literal value."""
    decl = decls.get(name.casefold())
    if decl is None or decl.datatype.casefold() != datatype:
        declared = ", ".join(d.name for d in decls.values() if d.datatype.casefold() == datatype)
        raise RapidError(
            f"{label}: no {datatype} {name!r} is declared at module level "
            f"(declared: {declared or 'none'})"
        )
    if decl.value is None or decl.value.kind != "agg" or len(decl.value.items) < 3:
        raise RapidError(
            f"{location(label, decl.line)}: the {datatype} {decl.name} has no literal value "
            "to rewrite"
        )
    return decl


def _target_edits(text: str, value: Node, new: TargetRewrite) -> list[tuple[int, int, str]]:
    trans, rot, conf = value.items[:3]
    separator = separator_of(text[value.start : value.end])
    return [
        (trans.start, trans.end, position_text(new.T_wobj_tcp, separator)),
        (rot.start, rot.end, orientation_text(new.T_wobj_tcp, separator)),
        (conf.start, conf.end, f"[{separator.join(str(int(c)) for c in new.conf)}]"),
    ]


def with_rewritten(
    text: str,
    label: str,
    targets: Mapping[str, TargetRewrite],
    tools: Mapping[str, np.ndarray] | None = None,
) -> str:
    """The module `text` (read from `label`, named in errors) with the module-level robtargets
    named in `targets` (any case) given their new pose and configuration data, and the
    tooldata named in `tools` their TCP frame T_flange_tcp (4, 4) [m]. Every other character
    (names, order, speeds, zones, comments, other data, whitespace, line endings) is kept; a
    CONST is rewritten too. Raises RapidError naming what is declared when a name is no
    robtarget (or tooldata) of the module, or one without a literal value."""
    parser = Parser(text, label)
    parser.module()
    decls = {d.name.casefold(): d for d in parser.decls if d.routine is None}
    edits: list[tuple[int, int, str]] = []
    for name, new in targets.items():
        value = _declaration(decls, name, "robtarget", label).value
        assert value is not None  # _declaration checked it
        edits += _target_edits(text, value, new)
    for name, T_flange_tcp in (tools or {}).items():
        value = _declaration(decls, name, "tooldata", label).value
        assert value is not None
        tframe = value.items[1]
        written = pose_text(T_flange_tcp, separator_of(text[tframe.start : tframe.end]))
        edits.append((tframe.start, tframe.end, written))
    for start, end, new_text in sorted(edits, reverse=True):
        text = text[:start] + new_text + text[end:]
    return text
