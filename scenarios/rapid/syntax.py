"""The syntax of a RAPID module, as the parser (scenarios.rapid.parser) reads it: the
expression and argument nodes, the data declarations, the instruction calls and routines of a
module, the module's syntax as a whole (`ParsedModule`) and its text with it (`ModuleText`),
and `RapidError`, the error every read of RAPID raises. Nothing here resolves a name:
scenarios.rapid.reader builds the typed module from this syntax.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from scenarios.scenario_errors import ScenarioError


class RapidError(ScenarioError, ValueError):
    """A RAPID module that cannot be read or used: the message names the file (if any), the
    line and what is wrong."""


class EncryptedModuleError(RapidError):
    """A module file that is not RAPID text: a controller's encrypted module (which only a
    controller can load) or any binary file."""


def location(source: str | None, line: int) -> str:
    """Where a message points: "<source>, line N" (or "line N" without a source)."""
    return f"{source}, line {line}" if source else f"line {line}"


@dataclass(frozen=True)
class Routine:
    """A routine of a module: its kind ("PROC", "FUNC" or "TRAP"), its name as declared,
    whether it is LOCAL (visible in its own module only), its parameters (case-folded) and
    the line it starts at."""

    kind: str
    name: str
    local: bool
    parameters: frozenset[str]
    line: int


#: The attributes a MODULE may declare.
MODULE_ATTRIBUTES = ("SYSMODULE", "NOSTEPIN", "VIEWONLY", "READONLY", "NOVIEW")


# ---------------------------------------------------------------------------------------------
# Syntax tree: expressions, arguments, declarations, instruction calls


@dataclass(frozen=True)
class Node:
    """An expression: "num", "str", "bool" (value), "placeholder" (value: its text, e.g.
    "<EXP>"), "name" (value: the text, with any
    .field / {index}), "agg" (items), "call" (value: the function, args), "unary" (value: the
    operator, items: the operand) or "binary" (value: the operator, items: both operands).
    start:end is its text."""

    kind: str
    start: int
    end: int
    line: int
    value: object = None
    items: tuple[Node, ...] = ()
    args: tuple[Arg, ...] = ()


@dataclass(frozen=True)
class Arg:
    """An argument: positional (name None), named (Name := value) or optional (\\Name, with
    or without := value)."""

    name: str | None
    optional: bool
    value: Node | None
    start: int
    end: int


@dataclass(frozen=True)
class Decl:
    """A data declaration as written: its name, data type, storage (PERS, CONST, VAR), scope
    (LOCAL, TASK or ""), whether it is an array, its initial value (None: none), its line and
    the routine it is declared in (None: at module level)."""

    name: str
    datatype: str
    storage: str
    scope: str
    array: bool
    value: Node | None
    line: int
    routine: str | None


@dataclass(frozen=True)
class Call:
    """An instruction statement as written (any name: RAPID's or a procedure's): its name,
    its arguments, its line, the routine it is in and the FOR variables bound there
    (case-folded)."""

    name: str
    args: tuple[Arg, ...]
    line: int
    routine: str
    loop_vars: frozenset[str]


@dataclass
class ParsedModule:
    """The syntax of one module: its name, data declarations, routines' parameters, calls,
    routines, RECORD and ALIAS names, attributes, `%%%` header and placeholders."""

    name: str
    decls: list[Decl]
    params: dict[str, frozenset[str]]  # routine (casefold) -> its parameters (casefold)
    calls: list[Call]
    routines: list[Routine]
    records: list[str]
    attributes: tuple[str, ...]
    header: tuple[tuple[str, str], ...]
    placeholders: list[tuple[str, int]]


def as_float(value: object) -> float:
    """A number literal's value (the parser stores it as a float)."""
    assert isinstance(value, int | float), value
    return float(value)


@dataclass(frozen=True, eq=False)
class ModuleText:
    """A module's text parsed but not yet resolved: its file (None for a text), the label
    its messages use, the text and the syntax the parser read (scenarios.rapid.task resolves
    names across the modules of a task before building each)."""

    path: Path | None
    label: str | None
    text: str
    parsed: ParsedModule

    @property
    def name(self) -> str:
        return self.parsed.name

    def global_data(self) -> dict[str, Decl]:
        """Its module-level data visible to other modules (not LOCAL), by case-folded name."""
        return {
            d.name.casefold(): d
            for d in self.parsed.decls
            if d.routine is None and d.scope != "LOCAL"
        }
