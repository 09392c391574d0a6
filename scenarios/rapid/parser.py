"""The RAPID parser: a module's text (a file's bytes checked to be text, not an encrypted or
binary module: scenarios.rapid.lexer) tokenized and parsed by recursive descent into its
syntax (scenarios.rapid.syntax): data declarations, routines (PROC, FUNC, TRAP with their
handlers), RECORD and ALIAS types, the `%%%` header, the module's attributes, and every
instruction statement whatever its name; its expressions and arguments are parsed by
scenarios.rapid.expression_parser. It resolves no name: scenarios.rapid.reader builds a
typed module from the syntax, scenarios.rapid.task resolves names across the modules of a
task, scenarios.rapid.flow follows the statements.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import ClassVar

from scenarios.rapid.expression_parser import ExpressionParser
from scenarios.rapid.lexer import BLOCK_WORDS, RESERVED, Token, check_text, read_text
from scenarios.rapid.syntax import (
    MODULE_ATTRIBUTES,
    Call,
    Decl,
    ModuleText,
    ParsedModule,
    RapidError,
    Routine,
)


class Parser(ExpressionParser):
    """Recursive descent over the tokens of one module (its expressions and arguments: see
    ExpressionParser):

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
    """

    def __init__(self, text: str, source: str | None) -> None:
        super().__init__(text, source)
        self.decls: list[Decl] = []
        self.params: dict[str, frozenset[str]] = {}
        self.calls: list[Call] = []
        self.routines: list[Routine] = []
        self.records: list[str] = []
        self.routine: str | None = None
        self.loop_vars: list[str] = []

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

    def skip_to(self, closer: str, opener: Token, what: str) -> None:
        """Skip the tokens up to and including `closer` (a keyword or an operator)."""
        while not self.at(closer):
            if self.peek().kind == "eof":
                raise self.error(opener.line, f"{what} has no {closer}")
            self.next()
        self.next()

    # --- module

    def module(self) -> ParsedModule:
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
        return ParsedModule(
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
            Decl(
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
            if tok.kind == "eof" or tok.word() in BLOCK_WORDS or routine_next:
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
            self.calls.append(Call(name, (), tok.line, self.routine, frozenset(self.loop_vars)))
        elif tok.kind != "name":
            raise self.error(tok.line, f"expected an instruction, found {tok.describe()}")
        elif word in self._STATEMENTS:
            self._STATEMENTS[word](self)
        elif word in RESERVED:
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
            Call(name.text, tuple(args), name.line, self.routine, frozenset(self.loop_vars))
        )

    # The statements that start with a keyword, by keyword.
    _STATEMENTS: ClassVar[dict[str, Callable[[Parser], None]]] = {
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


def parse_module(source: str | Path, name: str | None = None) -> ModuleText:
    """Parse a RAPID module (its text, or its file as a Path) without resolving its names;
    raises RapidError naming the file and line on a syntax error, or a file that is
    encrypted or binary."""
    if isinstance(source, Path):
        path: Path | None = source
        text = read_text(source)
        label: str | None = name or str(source)
    elif "\n" not in source and re.search(r"\.(mod|modx|sys|prg)\s*$", source, re.IGNORECASE):
        raise RapidError(f"{source!r} looks like a file name: pass a Path to read a file")
    else:
        path, text, label = None, source, name
        check_text(text, label)
    return ModuleText(path, label, text, Parser(text, label).module())
