"""The RAPID parser: a module's text (a file's bytes checked to be text, not an encrypted or
binary module) tokenized and parsed by recursive descent into its syntax: data declarations,
routines (PROC, FUNC, TRAP with their handlers), RECORD and ALIAS types, the `%%%` header,
the module's attributes, and every instruction statement whatever its name. It resolves no
name: scenarios.rapid.module builds a typed module from the syntax, scenarios.rapid.task
resolves names across the modules of a task, scenarios.rapid.flow follows the statements.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import ClassVar

from scenarios.errors import ScenarioError


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


class RapidError(ScenarioError, ValueError):
    """A RAPID module that cannot be read or used: the message names the file (if any), the
    line and what is wrong."""


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
