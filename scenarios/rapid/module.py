"""An ABB RAPID module written in RobotStudio for the virtual cell: read it, take the
approach/touch moves of one work object as the operations to correct, and write it back with
only that work object's object frame (`oframe`) changed.

RAPID is in millimetres and scalar-first quaternions [q1 = w, q2, q3, q4]; everything read is
converted at this edge to metres and 4 x 4 homogeneous transforms. A robtarget is the TCP pose
in its work object's object frame, so the controller moves the TCP to
uframe @ oframe @ robtarget: correcting `oframe` corrects every target of that work object.

The reader is a small tokenizer and a recursive-descent parser of the module, its data
declarations and its routines. It does not run the program: data are taken at their declared
values, and a target that depends on run-time values (a routine parameter, a FOR variable, a
function such as CRobT) is kept with no pose.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.errors import ScenarioError

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


def _words(text: str) -> frozenset[str]:
    return frozenset(text.split())


# RAPID's reserved words (not names of data or instructions).
_RESERVED = _words(
    "ALIAS AND BACKWARD CASE CONNECT CONST DEFAULT DIV DO ELSE ELSEIF ENDFOR ENDFUNC ENDIF "
    "ENDMODULE ENDPROC ENDRECORD ENDTEST ENDTRAP ENDWHILE ERROR EXIT FALSE FOR FROM FUNC GOTO "
    "IF INOUT LOCAL MOD MODULE NOSTEPIN NOT NOVIEW OR PERS PROC RAISE READONLY RECORD RETRY "
    "RETURN STEP SYSMODULE TASK TEST THEN TO TRAP TRUE TRYNEXT UNDO VAR VIEWONLY WHILE WITH "
    "XOR"
)
# Words that open or close a routine or a block: a statement never starts with one.
_BLOCK_WORDS = _words(
    "MODULE ENDMODULE PROC ENDPROC FUNC ENDFUNC TRAP ENDTRAP RECORD ENDRECORD ENDIF ELSE "
    "ELSEIF ENDFOR ENDWHILE ENDTEST CASE DEFAULT BACKWARD ERROR UNDO THEN DO"
)
# Data every controller declares in its BASE module.
_PREDEFINED = {"tool0": "tooldata", "wobj0": "wobjdata", "load0": "loaddata"}

_QUATERNION_NORM_TOLERANCE = 1e-3


class RapidError(ScenarioError, ValueError):
    """A RAPID module that cannot be read or used: the message names the file (if any), the
    line and what is wrong."""


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
class Routine:
    """A routine of a module: its kind ("PROC", "FUNC" or "TRAP"), its name as declared,
    whether it is LOCAL (visible in its own module only), its parameters (case-folded) and
    the line it starts at."""

    kind: str
    name: str
    local: bool
    parameters: frozenset[str]
    line: int


@dataclass(frozen=True)
class Instruction:
    """An instruction statement as written (a move, a RAPID instruction or a call of a
    procedure): its name, its line, the routine it is in."""

    name: str
    line: int
    routine: str


#: The attributes a MODULE may declare.
MODULE_ATTRIBUTES = ("SYSMODULE", "NOSTEPIN", "VIEWONLY", "READONLY", "NOVIEW")


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


@dataclass(frozen=True, eq=False)
class TouchOperation:
    """An operation to correct: the approach and touch TCP poses in the work object's object
    frame T_wobj_approach, T_wobj_touch (4, 4) [m], the touch move's speed as written and its
    line. The name is the touch target's name (or expression) as written."""

    name: str
    T_wobj_approach: np.ndarray
    T_wobj_touch: np.ndarray
    speed_touch: str
    line: int


# ---------------------------------------------------------------------------------------------
# Tokens


@dataclass(frozen=True)
class _Token:
    kind: str  # "name", "num", "str", "op" or "eof"
    text: str
    start: int
    end: int
    line: int

    def word(self) -> str:
        """The upper-case text of a name (RAPID's keywords are case-insensitive), else ""."""
        return self.text.upper() if self.kind == "name" else ""

    def describe(self) -> str:
        return "the end of the file" if self.kind == "eof" else f"{self.text!r} at line {self.line}"


_TOKEN = re.compile(
    r"(?P<space>[ \t\r\n\f\v\ufeff]+)"
    r"|(?P<comment>![^\n]*)"
    r"|(?P<num>0[xX][0-9A-Fa-f]+|0[bB][01]+|0[oO][0-7]+|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
    r'|(?P<str>"(?:[^"\\\n]|""|\\.)*")'
    r"|(?P<op>:=|<>|<=|>=|[\[\](){},;:\\.+\-*/<>=%?|])"
)


def _where(source: str | None, line: int) -> str:
    return f"{source}, line {line}" if source else f"line {line}"


def _tokenize(text: str, source: str | None) -> list[_Token]:
    tokens, pos, line = [], 0, 1
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            what = "unterminated string" if text[pos] == '"' else f"unexpected {text[pos]!r}"
            raise RapidError(f"{_where(source, line)}: {what}")
        kind = m.lastgroup
        assert kind is not None
        if kind == "num" and re.match(r"[A-Za-z_]", text[m.end() : m.end() + 1]):
            word = re.match(r"\w+", text[pos:])
            assert word is not None
            raise RapidError(
                f"{_where(source, line)}: the name {word.group()!r} starts with a digit (a "
                "RAPID name starts with a letter)"
            )
        if kind not in ("space", "comment"):
            tokens.append(_Token(kind, m.group(), m.start(), m.end(), line))
        line += m.group().count("\n")
        pos = m.end()
    tokens.append(_Token("eof", "", len(text), len(text), line))
    return tokens


# ---------------------------------------------------------------------------------------------
# Syntax tree: expressions, arguments, declarations, instruction calls


@dataclass(frozen=True)
class _Node:
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
    items: tuple[_Node, ...] = ()
    args: tuple[_Arg, ...] = ()


@dataclass(frozen=True)
class _Arg:
    """An argument: positional (name None), named (Name := value) or optional (\\Name, with
    or without := value)."""

    name: str | None
    optional: bool
    value: _Node | None
    start: int
    end: int


@dataclass(frozen=True)
class _Decl:
    name: str
    datatype: str
    storage: str
    scope: str
    array: bool
    value: _Node | None
    line: int
    routine: str | None


@dataclass(frozen=True)
class _Call:
    name: str
    args: tuple[_Arg, ...]
    line: int
    routine: str
    loop_vars: frozenset[str]


@dataclass
class _Parsed:
    name: str
    decls: list[_Decl]
    params: dict[str, frozenset[str]]  # routine (casefold) -> its parameters (casefold)
    calls: list[_Call]
    routines: list[Routine]
    records: list[str]
    attributes: tuple[str, ...]
    header: tuple[tuple[str, str], ...]
    placeholders: list[tuple[str, int]]


# ---------------------------------------------------------------------------------------------
# Parser


_BINARY = {
    "OR": 1,
    "XOR": 1,
    "AND": 2,
    "=": 3,
    "<>": 3,
    "<": 3,
    "<=": 3,
    ">": 3,
    ">=": 3,
    "+": 4,
    "-": 4,
    "*": 5,
    "/": 5,
    "DIV": 5,
    "MOD": 5,
}


def _as_float(value: object) -> float:
    """A number literal's value (the parser stores it as a float)."""
    assert isinstance(value, int | float), value
    return float(value)


class _Parser:
    """Recursive descent over the tokens of one module:

    file        := ['%%%' {KEY ':' value} '%%%'] module
    module      := MODULE name ['(' attribute {',' attribute} ')'] {item} ENDMODULE
    item        := [LOCAL | TASK] (declaration | routine | record | alias)
    declaration := (PERS | CONST | VAR) type name ['{' dims '}'] [':=' expr] ';'
    routine     := PROC name '(' params ')' block {(BACKWARD | ERROR | UNDO) block} ENDPROC
                 | FUNC type name '(' params ')' block {(ERROR | UNDO) block} ENDFUNC
                 | TRAP name block {(ERROR | UNDO) block} ENDTRAP
    record      := RECORD name {type name ';'} ENDRECORD;  alias := ALIAS type name ';'
    statement   := IF | FOR | WHILE | TEST | RETURN | GOTO | CONNECT | declaration | label ':'
                 | target ':=' expr ';' | '%' expr '%' [arguments] ';'
                 | instruction [arguments] ';'   (any name: RAPID's or a procedure's)
                 | placeholder
    placeholder := '<' NAME '>'   (also for an item, a value or a name: <DDN>, <EXP>, ...)
    arguments   := argument {',' argument | optional}
    argument    := optional | [name ':='] expr
    optional    := '\\' name [':=' expr | '?' name]
    expr        := unary {binary-operator expr}   (by precedence)
    primary     := number | string | TRUE | FALSE | '[' expr {',' expr} ']' | '(' expr ')'
                 | name '(' arguments ')' | name {'.' name | '{' expr {',' expr} '}'}
    """

    def __init__(self, text: str, source: str | None) -> None:
        self.text = text
        self.source = source
        self.tokens = _tokenize(text, source)
        self.i = 0
        self.decls: list[_Decl] = []
        self.params: dict[str, frozenset[str]] = {}
        self.calls: list[_Call] = []
        self.routines: list[Routine] = []
        self.records: list[str] = []
        self.placeholders: list[tuple[str, int]] = []
        self.routine: str | None = None
        self.loop_vars: list[str] = []

    # --- tokens

    def peek(self, k: int = 0) -> _Token:
        return self.tokens[min(self.i + k, len(self.tokens) - 1)]

    def next(self) -> _Token:
        tok = self.peek()
        self.i = min(self.i + 1, len(self.tokens) - 1)
        return tok

    def at(self, *texts: str) -> bool:
        """The next token is one of these keywords (any case) or operators."""
        tok = self.peek()
        if tok.kind == "name":
            return tok.word() in texts
        return tok.kind == "op" and tok.text in texts

    def error(self, line: int, message: str) -> RapidError:
        return RapidError(f"{_where(self.source, line)}: {message}")

    def expect(self, text: str, context: str) -> _Token:
        if not self.at(text):
            tok = self.peek()
            raise self.error(tok.line, f"expected {text!r} {context}, found {tok.describe()}")
        return self.next()

    def identifier(self, context: str) -> _Token:
        tok = self.peek()
        if tok.kind != "name" or tok.word() in _RESERVED:
            raise self.error(tok.line, f"expected a name {context}, found {tok.describe()}")
        return self.next()

    def end_statement(self, context: str) -> None:
        """The ';' that ends a declaration or a statement."""
        if self.at(";"):
            self.next()
            return
        tok, last = self.peek(), self.tokens[self.i - 1]
        if tok.text in ("]", ")", "}"):
            raise self.error(
                tok.line, f"unbalanced brackets: {tok.text!r} closes nothing in {context}"
            )
        raise self.error(last.line, f"missing ';' after {context} (found {tok.describe()})")

    def skip_to(self, closer: str, opener: _Token, what: str) -> None:
        """Skip the tokens up to and including `closer` (a keyword or an operator)."""
        while not self.at(closer):
            if self.peek().kind == "eof":
                raise self.error(opener.line, f"{what} has no {closer}")
            self.next()
        self.next()

    # --- module

    def module(self) -> _Parsed:
        header = self.header()
        self.expect("MODULE", "at the start of the module")
        opener = self.tokens[self.i - 1]
        name = self.identifier("after MODULE").text
        attributes = self.attributes(name) if self.at("(") else ()
        while not self.at("ENDMODULE"):
            tok = self.peek()
            if tok.kind == "eof":
                raise self.error(opener.line, f"MODULE {name} has no ENDMODULE")
            if self.at_placeholder():  # <DDN>, <RDN>, <TDN>: a declaration not written yet
                self.placeholder()
                continue
            scope = self.next().word() if self.at("LOCAL", "TASK") else ""
            if self.at("PERS", "CONST", "VAR"):
                self.declaration(scope)
            elif self.at("PROC", "FUNC", "TRAP"):
                self.routine_declaration(scope == "LOCAL")
            elif self.at("RECORD"):
                self.record()
            elif self.at("ALIAS"):
                self.alias()
            else:
                tok = self.peek()
                raise self.error(
                    tok.line,
                    f"expected a data declaration (PERS, CONST, VAR), a routine (PROC, FUNC, "
                    f"TRAP), a RECORD or an ALIAS, found {tok.describe()}",
                )
        end = self.next()
        if self.peek().kind != "eof":
            raise self.error(end.line, f"text after ENDMODULE: {self.peek().describe()}")
        return _Parsed(
            name,
            self.decls,
            self.params,
            self.calls,
            self.routines,
            self.records,
            attributes,
            header,
            self.placeholders,
        )

    def header(self) -> tuple[tuple[str, str], ...]:
        """The classic file header: '%%%' {KEY ':' value} '%%%' (e.g. VERSION:1,
        LANGUAGE:ENGLISH), or nothing."""
        if not self.at("%"):
            return ()
        opener = self.peek()
        for _ in range(3):
            self.expect("%", "in the '%%%' header")
        fields: list[tuple[str, str]] = []
        while not self.at("%"):
            key = self.identifier("(a header field such as VERSION:1) in the '%%%' header")
            self.expect(":", f"after {key.text} in the '%%%' header")
            value = self.next()
            if value.kind not in ("name", "num"):
                raise self.error(
                    value.line, f"expected the value of {key.text}, found {value.describe()}"
                )
            fields.append((key.text.upper(), value.text))
        for _ in range(3):
            self.expect("%", f"to close the '%%%' header of line {opener.line}")
        return tuple(fields)

    def attributes(self, module: str) -> tuple[str, ...]:
        """'(' attribute {',' attribute} ')' after MODULE name."""
        self.next()
        found: list[str] = []
        while True:
            tok = self.next()
            if tok.word() not in MODULE_ATTRIBUTES:
                raise self.error(
                    tok.line,
                    f"MODULE {module}: {tok.describe()} is not a module attribute (valid: "
                    f"{', '.join(MODULE_ATTRIBUTES)})",
                )
            found.append(tok.word())
            if self.at(")"):
                self.next()
                return tuple(found)
            self.expect(",", f"between the attributes of MODULE {module}")

    def record(self) -> None:
        """RECORD name {type field ';'} ENDRECORD."""
        start = self.next()
        name = self.identifier("after RECORD")
        while not self.at("ENDRECORD"):
            if self.peek().kind == "eof":
                raise self.error(start.line, f"RECORD {name.text} has no ENDRECORD")
            datatype = self.identifier(f"(a component's data type) in RECORD {name.text}")
            self.identifier(f"(a component's name) after {datatype.text}")
            self.end_statement(f"a component of RECORD {name.text}")
        self.next()
        self.records.append(name.text)

    def alias(self) -> None:
        """ALIAS type name ';'."""
        self.next()
        datatype = self.identifier("(a data type) after ALIAS")
        name = self.identifier(f"after ALIAS {datatype.text}")
        self.end_statement(f"ALIAS {datatype.text} {name.text}")
        self.records.append(name.text)

    def declaration(self, scope: str) -> None:
        storage = self.next()
        datatype = self.identifier(f"(a data type) after {storage.word()}")
        name = self.identifier(f"after the data type {datatype.text}")
        array = self.at("{")
        if array:
            self.next()
            self.expressions("}", name)
        value = None
        if self.at(":="):
            self.next()
            value = self.expression()
        self.end_statement(f"the declaration of {name.text}")
        self.decls.append(
            _Decl(
                name.text,
                datatype.text,
                storage.word(),
                scope,
                array,
                value,
                storage.line,
                self.routine,
            )
        )

    def routine_declaration(self, local: bool) -> None:
        """PROC, FUNC or TRAP up to its END word (its handlers included)."""
        start = self.next()
        kind = start.word()
        if kind == "FUNC":
            self.identifier("(the returned data type) after FUNC")
        name = self.identifier(f"after {kind}")
        params: frozenset[str] = frozenset()
        if kind != "TRAP":
            self.expect("(", f"after {kind} {name.text}")
            params = self.parameters()
        self.params[name.text.casefold()] = params
        self.routines.append(Routine(kind, name.text, local, params, start.line))
        self.routine = name.text
        what = f"{kind} {name.text} (line {start.line})"
        ends = ("BACKWARD", "ERROR", "UNDO", f"END{kind}")
        self.block(ends, what)
        while not self.at(ends[-1]):
            section = self.next()
            if section.word() == "ERROR" and self.at("("):
                self.skip_to(")", self.next(), f"the ERROR list of {what}")
            self.block(ends, what)
        self.next()
        self.routine = None

    def parameters(self) -> frozenset[str]:
        """The parameter names up to the closing ')': in each parameter, separated by ',', '|'
        or the '\\' of an optional one, the last name before any '{' (after INOUT / VAR /
        PERS and the type)."""
        names: set[str] = set()
        last: str | None = None
        depth = 0
        while not (self.at(")") and depth == 0):
            tok = self.next()
            if tok.kind == "eof":
                raise self.error(tok.line, "the parameter list has no ')'")
            if tok.text == "{":
                depth += 1
            elif tok.text == "}":
                depth -= 1
            elif depth == 0 and tok.text in (",", "|", "\\"):
                if last:
                    names.add(last)
                last = None
            elif depth == 0 and tok.kind == "name":
                last = tok.text.casefold()
        if last:
            names.add(last)
        self.next()
        return frozenset(names)

    # --- statements

    def block(self, ends: tuple[str, ...], what: str) -> None:
        """Statements up to one of `ends` (not consumed); ends[-1] closes `what`."""
        while not self.at(*ends):
            tok = self.peek()
            routine_next = tok.word() in ("LOCAL", "TASK") and self.peek(1).word() in (
                "PROC",
                "FUNC",
                "TRAP",
                "RECORD",
            )
            if tok.kind == "eof" or tok.word() in _BLOCK_WORDS or routine_next:
                raise self.error(tok.line, f"{what} has no {ends[-1]} (found {tok.describe()})")
            self.statement()

    def statement(self) -> None:
        """One statement: a keyword's (see _STATEMENTS), a label, an assignment, a late-bound
        call or an instruction."""
        tok = self.peek()
        word = tok.word()
        if tok.text == "%":
            self.late_bound_call()
        elif self.at_placeholder():  # <SMT>: a statement not written yet
            name = self.placeholder()
            assert self.routine is not None
            self.calls.append(_Call(name, (), tok.line, self.routine, frozenset(self.loop_vars)))
        elif tok.kind != "name":
            raise self.error(tok.line, f"expected an instruction, found {tok.describe()}")
        elif word in self._STATEMENTS:
            self._STATEMENTS[word](self)
        elif word in _RESERVED:
            raise self.error(tok.line, f"unexpected {tok.describe()}")
        elif self.peek(1).text == ":":  # a label
            self.next()
            self.next()
        elif self.peek(1).text in (":=", ".", "{"):
            self.assignment()
        else:
            self.instruction()

    def late_bound_call(self) -> None:
        """%"name"% arguments;"""
        start = self.next()
        self.expression()
        self.expect("%", "after the late-bound procedure name")
        self.arguments()
        self.end_statement(f"the late-bound call at line {start.line}")

    def assignment(self) -> None:
        """target := expr; with any .field / {index} of the assigned data."""
        start = self.peek()
        self.primary()
        self.expect(":=", f"in the assignment at line {start.line}")
        self.expression()
        self.end_statement(f"the assignment to {start.text}")

    def local_declaration(self) -> None:
        """A routine's data: [LOCAL | TASK] (PERS | CONST | VAR) ..."""
        scope = self.next().word() if self.at("LOCAL", "TASK") else ""
        self.declaration(scope)

    def for_statement(self) -> None:
        start = self.next()
        var = self.identifier("after FOR")
        self.expect("FROM", f"after FOR {var.text}")
        self.expression()
        self.expect("TO", "in the FOR statement")
        self.expression()
        if self.at("STEP"):
            self.next()
            self.expression()
        self.expect("DO", "in the FOR statement")
        self.loop_vars.append(var.text.casefold())
        self.block(("ENDFOR",), f"FOR (line {start.line})")
        self.loop_vars.pop()
        self.next()

    def while_statement(self) -> None:
        start = self.next()
        self.expression()
        self.expect("DO", "after the WHILE condition")
        self.block(("ENDWHILE",), f"WHILE (line {start.line})")
        self.next()

    def return_statement(self) -> None:
        """RETURN or RAISE, with an optional value."""
        word = self.next().word()
        if not self.at(";"):
            self.expression()
        self.end_statement(word)

    def bare_statement(self) -> None:
        """EXIT, RETRY or TRYNEXT."""
        self.end_statement(self.next().word())

    def goto_statement(self) -> None:
        self.next()
        self.identifier("after GOTO")
        self.end_statement("GOTO")

    def connect_statement(self) -> None:
        self.next()
        self.expression()
        self.expect("WITH", "in CONNECT")
        self.identifier("after WITH")
        self.end_statement("CONNECT")

    def if_statement(self) -> None:
        start = self.next()
        self.expression()
        if not self.at("THEN"):  # compact IF: one simple statement
            self.statement()
            return
        self.next()
        what = f"IF (line {start.line})"
        self.block(("ELSEIF", "ELSE", "ENDIF"), what)
        while self.at("ELSEIF"):
            self.next()
            self.expression()
            self.expect("THEN", "after the ELSEIF condition")
            self.block(("ELSEIF", "ELSE", "ENDIF"), what)
        if self.at("ELSE"):
            self.next()
            self.block(("ENDIF",), what)
        self.next()

    def test_statement(self) -> None:
        start = self.next()
        self.expression()
        what = f"TEST (line {start.line})"
        while self.at("CASE"):
            self.next()
            self.expression()
            while self.at(","):
                self.next()
                self.expression()
            self.expect(":", "after CASE")
            self.block(("CASE", "DEFAULT", "ENDTEST"), what)
        if self.at("DEFAULT"):
            self.next()
            self.expect(":", "after DEFAULT")
            self.block(("ENDTEST",), what)
        self.expect("ENDTEST", f"to close the {what}")

    def instruction(self) -> None:
        """Any instruction or procedure call, whatever its name (what it is is decided once
        the task's routines are known: scenarios.rapid.task)."""
        name = self.next()
        args = self.arguments()
        self.end_statement(f"the {name.text} instruction")
        assert self.routine is not None
        self.calls.append(
            _Call(name.text, tuple(args), name.line, self.routine, frozenset(self.loop_vars))
        )

    # The statements that start with a keyword, by keyword.
    _STATEMENTS: ClassVar[dict[str, Callable[[_Parser], None]]] = {
        "IF": if_statement,
        "FOR": for_statement,
        "WHILE": while_statement,
        "TEST": test_statement,
        "RETURN": return_statement,
        "RAISE": return_statement,
        "EXIT": bare_statement,
        "RETRY": bare_statement,
        "TRYNEXT": bare_statement,
        "GOTO": goto_statement,
        "CONNECT": connect_statement,
        **dict.fromkeys(("PERS", "CONST", "VAR", "LOCAL", "TASK"), local_declaration),
    }

    def arguments(self, closer: str = ";") -> list[_Arg]:
        args: list[_Arg] = []
        if self.at(closer):
            return args
        while True:
            start = self.peek()
            if self.at("\\"):
                self.next()
                name = self.identifier("after '\\'").text
                value = None
                if self.at(":="):
                    self.next()
                    value = self.expression()
                elif self.at("?"):  # \A?B: passed on only if the caller's B was given
                    self.next()
                    value = self.primary()
                args.append(_Arg(name, True, value, start.start, self.tokens[self.i - 1].end))
            else:
                name = None
                if start.kind == "name" and self.peek(1).text == ":=":
                    name = self.next().text
                    self.next()
                value = self.expression()
                args.append(_Arg(name, False, value, start.start, value.end))
            if self.at(","):
                self.next()
            elif not self.at("\\"):
                return args

    # --- expressions

    def expression(self, min_precedence: int = 1) -> _Node:
        left = self.unary()
        while True:
            tok = self.peek()
            op = tok.word() or (tok.text if tok.kind == "op" else "")
            if op not in _BINARY or _BINARY[op] < min_precedence:
                return left
            self.next()
            right = self.expression(_BINARY[op] + 1)
            left = _Node("binary", left.start, right.end, left.line, op, (left, right))

    def unary(self) -> _Node:
        tok = self.peek()
        if self.at("-", "+", "NOT"):
            self.next()
            operand = self.expression(3) if tok.word() == "NOT" else self.unary()
            return _Node("unary", tok.start, operand.end, tok.line, tok.text.upper(), (operand,))
        return self.primary()

    def primary(self) -> _Node:
        tok = self.next()
        if tok.kind == "num":
            return _Node("num", tok.start, tok.end, tok.line, _number(tok.text))
        if tok.kind == "str":
            return _Node("str", tok.start, tok.end, tok.line, _string(tok.text))
        if tok.word() in ("TRUE", "FALSE"):
            return _Node("bool", tok.start, tok.end, tok.line, tok.word() == "TRUE")
        if tok.text == "[":
            items = self.expressions("]", tok)
            return _Node("agg", tok.start, self.tokens[self.i - 1].end, tok.line, None, items)
        if tok.text == "(":
            inner = self.expression()
            self.close(")", tok)
            return replace(inner, start=tok.start, end=self.tokens[self.i - 1].end)
        if tok.kind == "name" and tok.word() not in _RESERVED:
            if self.at("("):
                opener = self.next()
                args = self.arguments(")")
                self.close(")", opener)
                end = self.tokens[self.i - 1].end
                return _Node("call", tok.start, end, tok.line, tok.text, (), tuple(args))
            while self.at(".", "{"):
                if self.next().text == ".":
                    self.identifier("after '.'")
                else:
                    self.expressions("}", self.tokens[self.i - 1])
            end = self.tokens[self.i - 1].end
            return _Node("name", tok.start, end, tok.line, self.text[tok.start : end])
        if tok.text == "<" and self.peek().kind == "name" and self.peek(1).text == ">":
            self.i -= 1  # <EXP>, <VAR>, <ARG>, <ID>: a value or a name not written yet
            name = self.placeholder()
            end = self.tokens[self.i - 1].end
            return _Node("placeholder", tok.start, end, tok.line, name)
        raise self.error(tok.line, f"expected a value, found {tok.describe()}")

    def at_placeholder(self) -> bool:
        """The next tokens are a placeholder: '<' NAME '>' (RAPID's marks of what a program
        does not hold yet: <SMT>, <EXP>, <DDN>, ...)."""
        return self.at("<") and self.peek(1).kind == "name" and self.peek(2).text == ">"

    def placeholder(self) -> str:
        """Consume a placeholder; its text ("<SMT>"), recorded with its line. A module with
        placeholders loads on a controller; reaching one stops the program."""
        opener = self.next()
        name = f"<{self.next().text.upper()}>"
        self.next()
        self.placeholders.append((name, opener.line))
        return name

    def expressions(self, closer: str, opener: _Token) -> tuple[_Node, ...]:
        """expr {',' expr} closer."""
        items = [self.expression()]
        while self.at(","):
            self.next()
            items.append(self.expression())
        self.close(closer, opener)
        return tuple(items)

    def close(self, closer: str, opener: _Token) -> None:
        if not self.at(closer):
            raise self.error(
                opener.line,
                f"unbalanced brackets: the {opener.text!r} at line {opener.line} is not closed "
                f"by {closer!r} (found {self.peek().describe()})",
            )
        self.next()


def _number(text: str) -> float:
    if text[:2].lower() in ("0x", "0b", "0o"):
        return float(int(text, 0))
    return float(text)


def _string(text: str) -> str:
    body = text[1:-1].replace('""', '"')
    return re.sub(
        r"\\([0-9A-Fa-f]{2}|\\)", lambda m: "\\" if m[1] == "\\" else chr(int(m[1], 16)), body
    )


# ---------------------------------------------------------------------------------------------
# Values: literals, poses


def _literal(node: _Node | None) -> object:
    """The Python value of a literal (float, bool, str, nested tuples), None if not one."""
    if node is None:
        return None
    if node.kind in ("num", "str", "bool"):
        return node.value
    if node.kind == "unary" and node.value in ("-", "+") and node.items[0].kind == "num":
        value = _as_float(node.items[0].value)
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


class _Builder:
    def __init__(
        self, parsed: _Parsed, text: str, source: str | None, outer: dict[str, _Decl]
    ) -> None:
        self.text = text
        self.source = source
        self.params = parsed.params
        self.outer = outer
        self.module_decls: dict[str, _Decl] = {}
        self.local_decls: dict[tuple[str, str], _Decl] = {}
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
            where = _where(source, decl.line)
            kind = decl.datatype.casefold()
            if kind == "robtarget":
                self.targets[decl.name] = _robtarget(decl.name, value, where, decl.line)
            elif kind == "tooldata":
                self.tools[decl.name] = _tool(decl.name, value, where, decl.line)
            elif kind == "wobjdata":
                self.wobjs[decl.name] = _wobj(decl.name, value, where, decl.line)

    def error(self, line: int, message: str) -> RapidError:
        return RapidError(f"{_where(self.source, line)}: {message}")

    def lookup(self, name: str, scope: _Scope) -> _Decl | str | None:
        """The declaration of a plain name seen from `scope`: _RUNTIME for a parameter or a
        FOR variable, the predefined data type for tool0 / wobj0 / load0, None if undeclared."""
        key = name.casefold()
        if key in scope.loop_vars or key in self.params.get(scope.routine.casefold(), ()):
            return _RUNTIME
        decl = (
            self.local_decls.get((scope.routine.casefold(), key))
            or self.module_decls.get(key)
            or self.outer.get(key)
        )
        return decl if decl is not None else _PREDEFINED.get(key)

    def check_declared(self, node: _Node, datatype: str, role: str, call: _Call) -> None:
        """A name used as `role` (a tooldata, wobjdata, jointtarget) must be declared as one."""
        if node.kind != "name":
            return
        base = re.match(r"[A-Za-z_]\w*", str(node.value))
        assert base is not None
        found = self.lookup(base.group(), _Scope(call.routine, call.loop_vars))
        if found is None:
            raise self.error(node.line, f"the {role} {base.group()} of {call.name} is not declared")
        kind = found.datatype if isinstance(found, _Decl) else found
        if found != _RUNTIME and kind.casefold() != datatype and base.group() == node.value:
            raise self.error(
                node.line, f"the {role} {node.value} of {call.name} is a {kind}, not a {datatype}"
            )

    def number(self, node: _Node, scope: _Scope, call: _Call) -> float | None:
        """A numeric argument [as written], None if known only at run time."""
        if node.kind == "num":
            return _as_float(node.value)
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
            if isinstance(found, _Decl) and found.datatype.casefold() == "num":
                value = _literal(found.value)
                return value if isinstance(value, float) else None
            if found == _RUNTIME:
                return None
            kind = found.datatype if isinstance(found, _Decl) else found
            raise self.error(node.line, f"{node.value} in {call.name} is a {kind}, not a num")
        return None

    def target_pose(self, node: _Node, scope: _Scope, call: _Call) -> np.ndarray | None:
        """T_wobj_tcp (4, 4) [m] of a move's target: a robtarget's name, an inline robtarget,
        Offs(...) or RelTool(...); None if known only at run time."""
        if node.kind == "agg":
            value = _literal(node)
            if value is None:
                return None
            where = _where(self.source, node.line)
            return _robtarget("(inline)", value, where, node.line).T_wobj_tcp
        if node.kind == "name":
            return self.named_pose(node, scope, call)
        if node.kind == "call" and str(node.value).casefold() in ("offs", "reltool"):
            return self.offset_pose(node, scope, call)
        if node.kind in ("call", "placeholder"):
            return None  # a function known at run time (CRobT, ...), or not written yet
        raise self.error(node.line, f"cannot read the target of {call.name}: {self.slice(node)}")

    def named_pose(self, node: _Node, scope: _Scope, call: _Call) -> np.ndarray | None:
        """T_wobj_tcp (4, 4) [m] of a robtarget named in a move (declared in the module or in
        the routine); None for a parameter, an array element or a field."""
        self.check_declared(node, "robtarget", "target", call)
        found = self.lookup(str(node.value), scope)  # None: an element or a field
        if not isinstance(found, _Decl) or found.array:
            return None
        if found.routine is None and self.module_decls.get(found.name.casefold()) is found:
            target = self.targets.get(found.name)
            return None if target is None else target.T_wobj_tcp.copy()
        value = _literal(found.value)  # declared in the routine, or in another module
        if value is None:
            return None
        where = _where(self.source, node.line)
        return _robtarget(found.name, value, where, node.line).T_wobj_tcp

    def offset_pose(self, node: _Node, scope: _Scope, call: _Call) -> np.ndarray | None:
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

    def slice(self, item: _Node | _Arg) -> str:
        return self.text[item.start : item.end]

    def move(self, call: _Call) -> Move:
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

    def declaration(self, decl: _Decl) -> Declaration:
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


# Characters no RAPID text holds (C0 and C1 controls other than blanks), as Latin-1 decodes
# the bytes of a binary or encrypted file.
_CONTROL = re.compile(r"[\x00-\x08\x0e-\x1f\x7f-\x9f]")
_TEXT_SAMPLE = 4096


def _check_text(text: str, label: str | None) -> None:
    """Refuse a file that is not text: a controller's encrypted module or any binary file
    (a NUL, more than 1 control character in 200, or a first character that is not printable
    ASCII, where RAPID starts with MODULE, '%%%' or a comment)."""
    sample = text[:_TEXT_SAMPLE]
    first = sample.lstrip(" \t\r\n\f\v\ufeff")[:1]
    controls = len(_CONTROL.findall(sample))
    if (
        "\x00" in sample
        or controls > max(2, len(sample) // 200)
        or (first and not (first.isascii() and first.isprintable()))
    ):
        raise RapidError(
            f"{label or 'the module'} is encrypted or binary, not RAPID text (an encrypted "
            "module can only be loaded by a controller)"
        )


def _read_text(path: Path) -> str:
    """The file's text as it is (line endings kept): UTF-8, else Latin-1; refuses a binary or
    encrypted file."""
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    _check_text(text, str(path))
    return text


@dataclass(frozen=True, eq=False)
class ModuleText:
    """A module's text parsed but not yet resolved: its file (None for a text), the label
    its messages use, the text and the syntax the parser read (scenarios.rapid.task resolves
    names across the modules of a task before building each)."""

    path: Path | None
    label: str | None
    text: str
    parsed: _Parsed

    @property
    def name(self) -> str:
        return self.parsed.name

    def global_data(self) -> dict[str, _Decl]:
        """Its module-level data visible to other modules (not LOCAL), by case-folded name."""
        return {
            d.name.casefold(): d
            for d in self.parsed.decls
            if d.routine is None and d.scope != "LOCAL"
        }


def parse_module(source: str | Path, name: str | None = None) -> ModuleText:
    """Parse a RAPID module (its text, or its file as a Path) without resolving its names;
    raises RapidError naming the file and line on a syntax error, or a file that is
    encrypted or binary."""
    if isinstance(source, Path):
        path: Path | None = source
        text = _read_text(source)
        label: str | None = name or str(source)
    elif "\n" not in source and re.search(r"\.(mod|modx|sys|prg)\s*$", source, re.IGNORECASE):
        raise RapidError(f"{source!r} looks like a file name: pass a Path to read a file")
    else:
        path, text, label = None, source, name
        _check_text(text, label)
    return ModuleText(path, label, text, _Parser(text, label).module())


def build_module(source: ModuleText, outer: dict[str, _Decl] | None = None) -> RapidModule:
    """The typed module of a parsed text, its names resolved in its own module and then in
    `outer` (the data other modules of its task make visible to it, by case-folded name).
    Raises RapidError naming the file and line for a move whose target, tool or work object
    is declared nowhere, or data that are not what their type needs."""
    parsed, text, label = source.parsed, source.text, source.label
    builder = _Builder(parsed, text, label, outer or {})
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


# ---------------------------------------------------------------------------------------------
# Operations: approach / touch pairs of one work object


def _label(module: RapidModule) -> str:
    return str(module.path) if module.path is not None else f"module {module.name}"


def _module_error(module: RapidModule, line: int, message: str) -> RapidError:
    return RapidError(f"{_where(_label(module), line)}: {message}")


def _find_wobj(module: RapidModule, wobj: str) -> WobjData:
    for name, data in module.wobjs.items():
        if name.casefold() == wobj.casefold():
            return data
    declared = ", ".join(module.wobjs) or "none"
    raise RapidError(f"{_label(module)}: no wobjdata {wobj!r} is declared (declared: {declared})")


def _same(a: str, b: str) -> bool:
    """Two targets as written are the same (RAPID names are case-insensitive)."""
    return re.sub(r"\s", "", a).casefold() == re.sub(r"\s", "", b).casefold()


_PAIRS_HINT = "list the (approach, touch) target pairs of this work object in the config"


def touch_operations(
    module: RapidModule, wobj: str, pairs: Sequence[tuple[str, str]] | None = None
) -> tuple[TouchOperation, ...]:
    """The approach/touch operations of the moves that use work object `wobj`.

    Without `pairs`, read from the program's pattern, in the order of the text: within one
    routine, a MoveL with a `fine` zone is a touch, and the move before it with the same work
    object (a MoveJ or a MoveL that is not itself a touch) its approach; a move right after a
    touch is the move back (or a transit); moves with another work object separate the
    patterns. With `pairs`, each (approach, touch) names a robtarget or a target expression
    as written in a move with `wobj` (e.g. "Offs(p10,0,0,50)"). Raises RapidError when the
    work object is not declared or no move uses it, or when the pattern cannot be read (then:
    list the pairs in the config)."""
    data = _find_wobj(module, wobj)
    moves = [
        m for m in module.moves if m.wobj is not None and m.wobj.casefold() == data.name.casefold()
    ]
    mine = {id(m) for m in moves}
    if not any(m.instruction.casefold() != "moveabsj" for m in moves):
        raise _module_error(
            module, data.line, f"the work object {data.name} holds no robtarget used in any move"
        )
    if pairs is not None:
        return tuple(_paired(module, moves, data, pair) for pair in pairs)
    operations: list[TouchOperation] = []
    previous: Move | None = None  # the move before, in the same routine, with the same wobj
    touch: TouchOperation | None = None  # the operation `previous` touched, if it is a touch
    for m in module.moves:
        if id(m) not in mine or (previous is not None and previous.routine != m.routine):
            previous = touch = None
            if id(m) not in mine:
                continue
        if not (m.instruction.casefold() == "movel" and m.zone.casefold() == "fine"):
            previous, touch = m, None
            continue
        if touch is not None and previous is not None:
            if m.T_wobj_tcp is not None and np.allclose(m.T_wobj_tcp, touch.T_wobj_approach):
                previous, touch = m, None  # the move back to the approach, stopping there
                continue
            raise _module_error(
                module,
                m.line,
                f"{m.instruction} {m.target} with a fine zone follows the touch at line "
                f"{previous.line} and does not go back to its approach: cannot tell approach "
                f"from touch; {_PAIRS_HINT}",
            )
        if previous is None or previous.instruction.casefold() not in ("movej", "movel"):
            raise _module_error(
                module,
                m.line,
                f"the touch {m.instruction} {m.target} has no MoveJ or MoveL approach with "
                f"{data.name} before it; {_PAIRS_HINT}",
            )
        if previous.T_wobj_tcp is None or m.T_wobj_tcp is None:
            late = previous if previous.T_wobj_tcp is None else m
            raise _module_error(
                module,
                late.line,
                f"the target {late.target} is known only at run time; {_PAIRS_HINT} with "
                "targets declared in the module",
            )
        touch = TouchOperation(m.target, previous.T_wobj_tcp, m.T_wobj_tcp, m.speed, m.line)
        operations.append(touch)
        previous = m
    if not operations:
        raise _module_error(
            module,
            data.line,
            f"no approach/touch pattern (a MoveL with a fine zone after a MoveJ or MoveL) "
            f"among the moves with {data.name}; {_PAIRS_HINT}",
        )
    return tuple(operations)


def _paired(
    module: RapidModule, moves: list[Move], data: WobjData, pair: tuple[str, str]
) -> TouchOperation:
    approach, touch = pair
    touch_move = next((m for m in moves if _same(m.target, touch)), None)
    if touch_move is None or touch_move.T_wobj_tcp is None:
        raise _module_error(
            module,
            data.line,
            f"no move with {data.name} goes to the touch target {touch!r} of the pair "
            f"({approach!r}, {touch!r})",
        )
    approach_move = next((m for m in moves if _same(m.target, approach)), None)
    if approach_move is not None and approach_move.T_wobj_tcp is not None:
        T_approach = approach_move.T_wobj_tcp
    else:
        target = next((t for n, t in module.targets.items() if _same(n, approach)), None)
        if target is None:
            raise _module_error(
                module,
                data.line,
                f"the approach target {approach!r} of the pair ({approach!r}, {touch!r}) is "
                f"neither a declared robtarget nor the target of a move with {data.name}",
            )
        T_approach = target.T_wobj_tcp
    return TouchOperation(
        touch_move.target, T_approach, touch_move.T_wobj_tcp, touch_move.speed, touch_move.line
    )


# ---------------------------------------------------------------------------------------------
# Writer


def _format(x: float, decimals: int) -> str:
    text = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0", "-") else text


def _pose_text(T: np.ndarray, separator: str = ",") -> str:
    """A RAPID pose [[x,y,z],[q1,q2,q3,q4]] of T (4, 4) [m]: mm to 4 decimals, the
    scalar-first unit quaternion to 8 decimals with q1 >= 0, trailing zeros dropped."""
    q = Rotation.from_matrix(T[:3, :3]).as_quat(scalar_first=True)
    q = q if q[0] >= 0 else -q
    p = separator.join(_format(v, 4) for v in T[:3, 3] * 1e3)
    return f"[[{p}]{separator}[{separator.join(_format(v, 8) for v in q)}]]"


def _check_transform(T: np.ndarray) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.allclose(T[3], [0, 0, 0, 1]):
        raise ValueError(f"T_uframe_oframe must be a (4, 4) homogeneous transform, got {T}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
        raise ValueError("the rotation of T_uframe_oframe is not a proper rotation")
    return T


def with_oframe(module: RapidModule, wobj: str, T_uframe_oframe: np.ndarray) -> str:
    """The module's text with only the `oframe` of work object `wobj` replaced by
    T_uframe_oframe (4, 4) [m], written in mm and a scalar-first quaternion (see _pose_text),
    with the separator the old oframe used (", " or ","). Every other character (names,
    order, comments, whitespace, line endings) is kept; a CONST wobjdata is edited too. Write
    the result back with the encoding the file was read with."""
    T = _check_transform(T_uframe_oframe)
    data = _find_wobj(module, wobj)
    parser = _Parser(module.text, _label(module))
    parser.module()
    decl = next(
        d for d in parser.decls if d.routine is None and d.name.casefold() == data.name.casefold()
    )
    assert decl.value is not None and decl.value.kind == "agg"  # read_module checked it
    oframe = decl.value.items[4]
    old = module.text[oframe.start : oframe.end]
    new = _pose_text(T, ", " if ", " in old else ",")
    return module.text[: oframe.start] + new + module.text[oframe.end :]
