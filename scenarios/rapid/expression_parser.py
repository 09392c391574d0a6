"""The RAPID parser's lower half: a cursor over a module's tokens and the recursive descent
of expressions and argument lists (the syntax nodes of scenarios.rapid.syntax), with RAPID's
operators by precedence and the placeholders of what a program does not hold yet. The
declarations, routines and statements are parsed on top of it (scenarios.rapid.parser).
"""

from __future__ import annotations

import re
from dataclasses import replace

from scenarios.rapid.lexer import RESERVED, Token, tokenize
from scenarios.rapid.syntax import Arg, Node, RapidError, location

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


class ExpressionParser:
    """Recursive descent over the tokens of one module, for its expressions:

    arguments   := argument {',' argument | optional}
    argument    := optional | [name ':='] expr
    optional    := '\\' name [':=' expr | '?' name]
    expr        := unary {binary-operator expr}   (by precedence)
    primary     := number | string | TRUE | FALSE | '[' expr {',' expr} ']' | '(' expr ')'
                 | name '(' arguments ')' | name {'.' name | '{' expr {',' expr} '}'}
                 | placeholder
    placeholder := '<' NAME '>'   (also for an item, a value or a name: <DDN>, <EXP>, ...)
    """

    def __init__(self, text: str, source: str | None) -> None:
        self.text = text
        self.source = source
        self.tokens = tokenize(text, source)
        self.i = 0
        self.placeholders: list[tuple[str, int]] = []

    # --- tokens

    def peek(self, k: int = 0) -> Token:
        return self.tokens[min(self.i + k, len(self.tokens) - 1)]

    def next(self) -> Token:
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
        return RapidError(f"{location(self.source, line)}: {message}")

    def expect(self, text: str, context: str) -> Token:
        if not self.at(text):
            tok = self.peek()
            raise self.error(tok.line, f"expected {text!r} {context}, found {tok.describe()}")
        return self.next()

    def identifier(self, context: str) -> Token:
        tok = self.peek()
        if tok.kind != "name" or tok.word() in RESERVED:
            raise self.error(tok.line, f"expected a name {context}, found {tok.describe()}")
        return self.next()

    # --- arguments

    def arguments(self, closer: str = ";") -> list[Arg]:
        args: list[Arg] = []
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
                args.append(Arg(name, True, value, start.start, self.tokens[self.i - 1].end))
            else:
                name = None
                if start.kind == "name" and self.peek(1).text == ":=":
                    name = self.next().text
                    self.next()
                value = self.expression()
                args.append(Arg(name, False, value, start.start, value.end))
            if self.at(","):
                self.next()
            elif not self.at("\\"):
                return args

    # --- expressions

    def expression(self, min_precedence: int = 1) -> Node:
        left = self.unary()
        while True:
            tok = self.peek()
            op = tok.word() or (tok.text if tok.kind == "op" else "")
            if op not in _BINARY or _BINARY[op] < min_precedence:
                return left
            self.next()
            right = self.expression(_BINARY[op] + 1)
            left = Node("binary", left.start, right.end, left.line, op, (left, right))

    def unary(self) -> Node:
        tok = self.peek()
        if self.at("-", "+", "NOT"):
            self.next()
            operand = self.expression(3) if tok.word() == "NOT" else self.unary()
            return Node("unary", tok.start, operand.end, tok.line, tok.text.upper(), (operand,))
        return self.primary()

    def primary(self) -> Node:
        tok = self.next()
        if tok.kind == "num":
            return Node("num", tok.start, tok.end, tok.line, _number(tok.text))
        if tok.kind == "str":
            return Node("str", tok.start, tok.end, tok.line, _string(tok.text))
        if tok.word() in ("TRUE", "FALSE"):
            return Node("bool", tok.start, tok.end, tok.line, tok.word() == "TRUE")
        if tok.text == "[":
            items = self.expressions("]", tok)
            return Node("agg", tok.start, self.tokens[self.i - 1].end, tok.line, None, items)
        if tok.text == "(":
            inner = self.expression()
            self.close(")", tok)
            return replace(inner, start=tok.start, end=self.tokens[self.i - 1].end)
        if tok.kind == "name" and tok.word() not in RESERVED:
            if self.at("("):
                opener = self.next()
                args = self.arguments(")")
                self.close(")", opener)
                end = self.tokens[self.i - 1].end
                return Node("call", tok.start, end, tok.line, tok.text, (), tuple(args))
            while self.at(".", "{"):
                if self.next().text == ".":
                    self.identifier("after '.'")
                else:
                    self.expressions("}", self.tokens[self.i - 1])
            end = self.tokens[self.i - 1].end
            return Node("name", tok.start, end, tok.line, self.text[tok.start : end])
        if tok.text == "<" and self.peek().kind == "name" and self.peek(1).text == ">":
            self.i -= 1  # <EXP>, <VAR>, <ARG>, <ID>: a value or a name not written yet
            name = self.placeholder()
            end = self.tokens[self.i - 1].end
            return Node("placeholder", tok.start, end, tok.line, name)
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

    def expressions(self, closer: str, opener: Token) -> tuple[Node, ...]:
        """expr {',' expr} closer."""
        items = [self.expression()]
        while self.at(","):
            self.next()
            items.append(self.expression())
        self.close(closer, opener)
        return tuple(items)

    def close(self, closer: str, opener: Token) -> None:
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
