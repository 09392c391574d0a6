"""The order in which a controller runs the statements of a RAPID module, from `main`.

`scenarios.rapid.module` reads a module's data and moves but not its control flow:
its moves come in the order of the text. A controller runs `main` statement by statement and
enters each routine it calls. This module follows that order for the programs an offline
cell program is made of: straight sequences of instructions and calls of routines without
arguments. It records the top-level statements of every routine with the same parser the
reader uses (so both agree on every line), and refuses what it cannot follow before anything
moves: IF, FOR, WHILE, TEST, GOTO, assignments (they change data the targets may depend on),
late-bound calls, calls with arguments and recursion. RETURN ends the routine it is in and
EXIT the program. A routine's error, backward and undo handlers run only when an error is
raised, which the executor never does (an error stops the execution): they are not followed.
"""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.rapid.module import (
    MOVES,
    Move,
    RapidError,
    RapidModule,
    _Arg,
    _Call,
    _Parser,
)

# Statements a sequence of instructions may hold besides instruction calls.
_DECLARATION = "declaration"
_LABEL = "label"
_CALL = "call"
_FLOW_WORDS = (
    "IF",
    "FOR",
    "WHILE",
    "TEST",
    "RETURN",
    "RAISE",
    "EXIT",
    "RETRY",
    "TRYNEXT",
    "GOTO",
    "CONNECT",
)


@dataclass(frozen=True, eq=False)
class Step:
    """One instruction as the controller runs it: its name as written, the routine it is
    written in, the chain of routine calls that led there (outermost first, `main` at
    the start), its line, its optional arguments as written (e.g. "\\On"), its positional
    arguments as written, and the move it is (None for an instruction that is not a move)."""

    instruction: str
    routine: str
    calls: tuple[str, ...]
    line: int
    options: tuple[str, ...]
    arguments: tuple[str, ...]
    move: Move | None


@dataclass(frozen=True)
class _Statement:
    routine: str
    line: int
    kind: str  # _CALL, _DECLARATION, _LABEL, "assignment", "late-bound call" or a flow word
    call: _Call | None


class _StatementParser(_Parser):
    """The reader's parser, recording the top-level statements of each routine's body (the
    statements nested in IF, FOR, WHILE and TEST are parsed by the reader as usual)."""

    def __init__(self, text: str, source: str | None) -> None:
        super().__init__(text, source)
        self.statements: list[_Statement] = []
        self._depth = 0
        self._blocks: dict[str, int] = {}

    def block(self, ends: tuple[str, ...], what: str) -> None:
        if self._depth == 0 and self.routine is not None:
            # The first block of a PROC is its body; BACKWARD, ERROR and UNDO follow it.
            self._blocks[self.routine] = self._blocks.get(self.routine, 0) + 1
        super().block(ends, what)

    def statement(self) -> None:
        top = self._depth == 0 and self.routine is not None and self._blocks[self.routine] == 1
        tok, after = self.peek(), self.peek(1)
        word = tok.word()
        n_calls = len(self.calls)
        self._depth += 1
        try:
            super().statement()
        finally:
            self._depth -= 1
        if not top:
            return
        assert self.routine is not None
        if tok.text == "%":
            kind = "late-bound call"
        elif word in _FLOW_WORDS:
            kind = word
        elif word in ("PERS", "CONST", "VAR", "LOCAL", "TASK"):
            kind = _DECLARATION
        elif after.text == ":":
            kind = _LABEL
        elif after.text in (":=", ".", "{"):
            kind = "assignment"
        else:
            kind = _CALL
        call = self.calls[n_calls] if kind == _CALL and len(self.calls) > n_calls else None
        self.statements.append(_Statement(self.routine, tok.line, kind, call))


def _label(module: RapidModule) -> str:
    return str(module.path) if module.path is not None else f"module {module.name}"


def program_error(module: RapidModule, line: int, message: str) -> RapidError:
    """A RapidError `<file>:<line>: <message>` about `module`."""
    return RapidError(f"{_label(module)}:{line}: {message}")


def execution_order(module: RapidModule, entry: str = "main") -> tuple[Step, ...]:
    """The instructions of `module` in the order a controller runs them from the routine
    `entry` (routine calls entered, RETURN and EXIT honoured; see the module's docstring).
    Raises RapidError naming the file and the line of the first statement it cannot
    follow, or if `entry` is not a PROC of the module."""
    parser = _StatementParser(module.text, _label(module))
    parser.module()
    move_calls = [c for c in parser.calls if c.name.casefold() in MOVES]
    if len(move_calls) != len(module.moves):  # the same parser read the same text
        raise RapidError(f"{_label(module)}: the module changed since it was read")
    moves = {id(c): m for c, m in zip(move_calls, module.moves, strict=True)}
    bodies: dict[str, list[_Statement]] = {}
    names: dict[str, str] = {}
    for statement in parser.statements:
        bodies.setdefault(statement.routine.casefold(), []).append(statement)
    for routine in parser.params:
        bodies.setdefault(routine, [])
    for tok, name in zip(parser.tokens, parser.tokens[1:], strict=False):
        if tok.word() == "PROC" and name.kind == "name":
            names[name.text.casefold()] = name.text
    if entry.casefold() not in bodies:
        declared = ", ".join(names.values()) or "none"
        raise RapidError(
            f"{_label(module)}: no PROC {entry} to start the program from (routines: {declared})"
        )

    steps: list[Step] = []

    def text(arg: _Arg) -> str:
        return module.text[arg.start : arg.end]

    def run(routine: str, chain: tuple[str, ...]) -> bool:
        """Run `routine`'s body; False if the program ended (EXIT)."""
        for s in bodies[routine.casefold()]:
            if s.kind in (_DECLARATION, _LABEL):
                continue
            if s.kind == "RETURN":
                return True
            if s.kind == "EXIT":
                return False
            if s.kind != _CALL or s.call is None:
                raise program_error(
                    module,
                    s.line,
                    f"{s.kind} in PROC {names.get(routine.casefold(), routine)}: the executor "
                    "runs straight sequences of instructions and calls of routines without "
                    "arguments (no IF, FOR, WHILE, TEST, GOTO, assignment or late-bound call)",
                )
            call = s.call
            key = call.name.casefold()
            if key in names:
                callee = names[key]
                if call.args:
                    raise program_error(
                        module,
                        s.line,
                        f"the call of PROC {callee} passes arguments; the executor calls "
                        "routines without arguments only",
                    )
                if parser.params.get(key):
                    raise program_error(
                        module,
                        s.line,
                        f"PROC {callee} takes parameters "
                        f"({', '.join(sorted(parser.params[key]))}); the executor calls "
                        "routines without arguments only",
                    )
                if key in (c.casefold() for c in chain):
                    raise program_error(
                        module,
                        s.line,
                        f"PROC {callee} calls itself through {' -> '.join(chain)} -> {callee}: "
                        "recursion is not executed",
                    )
                if not run(callee, (*chain, callee)):
                    return False
                continue
            optional = tuple(text(a) for a in call.args if a.optional)
            positional = tuple(text(a) for a in call.args if not a.optional)
            steps.append(
                Step(
                    call.name,
                    s.routine,
                    chain,
                    s.line,
                    optional,
                    positional,
                    moves.get(id(call)),
                )
            )
        return True

    run(names[entry.casefold()], (names[entry.casefold()],))
    return tuple(steps)
