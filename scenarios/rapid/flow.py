"""The order in which a controller runs the statements of a RAPID task, from `main`.

`scenarios.rapid.reader` reads a module's data and moves but not its control flow:
its moves come in the order of the text. A controller runs `main` (wherever in the task it is
defined) statement by statement and enters each routine it calls, in whichever module of the
task it is (scenarios.rapid.task resolves the names, LOCAL routines in their own module). This
module follows that order for the programs an offline cell program is made of: straight
sequences of instructions and calls of routines without arguments. It records the top-level
statements of every routine with the same parser the reader uses (so both agree on every
line), and refuses what it cannot follow before anything moves: IF, FOR, WHILE, TEST, GOTO,
assignments (they change data the targets may depend on), late-bound calls, calls with
arguments and recursion. RETURN ends the routine it is in and EXIT the program. A routine's
error, backward and undo handlers run only when an error is raised, which the executor never
does (an error stops the execution): they are not followed. Nor are TRAP routines: they run
on interrupts, which the executor does not raise; a CONNECT (an interrupt linked to its TRAP)
is a step that leaves the path as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.rapid.module import MOVES, Move, RapidModule
from scenarios.rapid.parser import Parser
from scenarios.rapid.syntax import Arg, Call, RapidError
from scenarios.rapid.task import ModuleScope, RapidTask, task_of

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
    arguments as written, the move it is (None for an instruction that is not a move) and
    the module it is written in."""

    instruction: str
    routine: str
    calls: tuple[str, ...]
    line: int
    options: tuple[str, ...]
    arguments: tuple[str, ...]
    move: Move | None
    module: RapidModule | None = None


@dataclass(frozen=True)
class _Statement:
    routine: str
    line: int
    kind: str  # _CALL, _DECLARATION, _LABEL, "assignment", "late-bound call" or a flow word
    call: Call | None


class _StatementParser(Parser):
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


def program_error(module: RapidModule | ModuleScope, line: int, message: str) -> RapidError:
    """A RapidError `<file>:<line>: <message>` about `module`."""
    return RapidError(f"{module.label}:{line}: {message}")


@dataclass(frozen=True, eq=False)
class _Program:
    """A module's routines as the statement parser read them: each PROC's top-level statements
    (by its name, case-folded), its parameters, its name as declared, and the move each move
    call is (by the call's identity)."""

    module: RapidModule
    bodies: dict[str, list[_Statement]]
    params: dict[str, frozenset[str]]
    names: dict[str, str]
    moves: dict[int, Move]

    def text(self, arg: Arg) -> str:
        """An argument as written."""
        return self.module.text[arg.start : arg.end]


def _read_program(module: RapidModule) -> _Program:
    """The routines of `module`, read again by the statement parser."""
    parser = _StatementParser(module.text, module.label)
    parser.module()
    move_calls = [c for c in parser.calls if c.name.casefold() in MOVES]
    if len(move_calls) != len(module.moves):  # the same parser read the same text
        raise RapidError(f"{module.label}: the module changed since it was read")
    moves = {id(c): m for c, m in zip(move_calls, module.moves, strict=True)}
    bodies: dict[str, list[_Statement]] = {}
    for statement in parser.statements:
        bodies.setdefault(statement.routine.casefold(), []).append(statement)
    names = {r.name.casefold(): r.name for r in parser.routines if r.kind == "PROC"}
    for routine in names:
        bodies.setdefault(routine, [])
    return _Program(module, bodies, parser.params, names, moves)


@dataclass(frozen=True, eq=False)
class _TaskProgram:
    """The task and each of its modules' routines (by the module's identity)."""

    task: RapidTask
    programs: dict[int, _Program]

    def callee(self, name: str, caller: RapidModule) -> tuple[_Program, str] | None:
        """The module's routines and the name as declared of the PROC `name` a statement of
        `caller` calls (see RapidTask.procedure), or None."""
        module = self.task.procedure(name, caller)
        if module is None:
            return None
        program = self.programs[id(module)]
        return program, program.names[name.casefold()]


def execution_order(program: RapidModule | RapidTask, entry: str = "main") -> tuple[Step, ...]:
    """The instructions of a module or a task in the order a controller runs them from the
    routine `entry`, wherever in the task it is defined (routine calls entered across
    modules, RETURN and EXIT honoured; see the module's docstring). Raises RapidError naming
    the file and the line of the first statement it cannot follow, or if `entry` is not a
    PROC of the task."""
    task = program if isinstance(program, RapidTask) else task_of(program)
    flow = _TaskProgram(task, {id(m): _read_program(m) for m in task.modules})
    found = flow.callee(entry, task.modules[0]) if task.modules else None
    if found is None:
        routines = [p.names[k] for p in flow.programs.values() for k in p.names]
        raise RapidError(
            f"{task.label}: no PROC {entry} to start the program from (routines: "
            f"{', '.join(routines) or 'none'})"
        )
    start, name = found
    steps: list[Step] = []
    _run(flow, start, name, (name,), steps)
    return tuple(steps)


def _run(
    flow: _TaskProgram, program: _Program, routine: str, chain: tuple[str, ...], steps: list[Step]
) -> bool:
    """Run `routine`'s body (in `program`'s module), called through `chain`, appending its
    instructions to `steps`; False if the program ended (EXIT)."""
    for s in program.bodies[routine.casefold()]:
        if s.kind in (_DECLARATION, _LABEL):
            continue
        if s.kind == "RETURN":
            return True
        if s.kind == "EXIT":
            return False
        if s.kind == "CONNECT":
            steps.append(Step("CONNECT", s.routine, chain, s.line, (), (), None, program.module))
            continue
        if s.kind != _CALL or s.call is None:
            raise program_error(
                program.module,
                s.line,
                f"{s.kind} in PROC {program.names.get(routine.casefold(), routine)}: the "
                "executor runs straight sequences of instructions and calls of routines without "
                "arguments (no IF, FOR, WHILE, TEST, GOTO, assignment or late-bound call)",
            )
        call = s.call
        found = flow.callee(call.name, program.module)
        if found is None:
            steps.append(_step(program, s, call, chain))
            continue
        callee_program, callee = found
        _check_call(program, callee_program, callee, s, call, chain)
        if not _run(flow, callee_program, callee, (*chain, callee), steps):
            return False
    return True


def _check_call(
    program: _Program,
    callee_program: _Program,
    callee: str,
    s: _Statement,
    call: Call,
    chain: tuple[str, ...],
) -> None:
    """Refuse a call (statement `s` of `program`, through `chain`) of the routine `callee` of
    `callee_program` that passes arguments, calls a routine with parameters, or recurses."""
    key = callee.casefold()
    if call.args:
        raise program_error(
            program.module,
            s.line,
            f"the call of PROC {callee} passes arguments; the executor calls "
            "routines without arguments only",
        )
    if callee_program.params.get(key):
        raise program_error(
            program.module,
            s.line,
            f"PROC {callee} takes parameters "
            f"({', '.join(sorted(callee_program.params[key]))}); the executor calls "
            "routines without arguments only",
        )
    if key in (c.casefold() for c in chain):
        raise program_error(
            program.module,
            s.line,
            f"PROC {callee} calls itself through {' -> '.join(chain)} -> {callee}: "
            "recursion is not executed",
        )


def _step(program: _Program, s: _Statement, call: Call, chain: tuple[str, ...]) -> Step:
    """The instruction `call` of statement `s`, reached through `chain`."""
    return Step(
        call.name,
        s.routine,
        chain,
        s.line,
        tuple(program.text(a) for a in call.args if a.optional),
        tuple(program.text(a) for a in call.args if not a.optional),
        program.moves.get(id(call)),
        program.module,
    )
