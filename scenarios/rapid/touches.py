"""The operations to correct in a RAPID module: the approach/touch moves of one work object,
read from the program's pattern or from the (approach, touch) target pairs the config lists.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from scenarios.rapid.module import Move, RapidModule, WobjData, find_wobj
from scenarios.rapid.syntax import RapidError, location


@dataclass(frozen=True, eq=False)
class TouchOperation:
    """An operation to correct: the approach and touch TCP poses in the work object's object
    frame T_wobj_approach, T_wobj_touch (4, 4) [m], the touch move's speed as written and its
    line. The name is the touch target's name (or expression) as written, `approach` the
    approach's (the approach move's target, or the pair's approach as listed); `comment` the
    name a comment line of one word (`! kocher_right`) right above the operation's first move
    gives it (its approach move; with listed pairs, the approach where it is the move just
    before the touch, else the touch), or None."""

    name: str
    T_wobj_approach: np.ndarray
    T_wobj_touch: np.ndarray
    speed_touch: str
    line: int
    approach: str
    comment: str | None = None


def _module_error(module: RapidModule, line: int, message: str) -> RapidError:
    return RapidError(f"{location(module.label, line)}: {message}")


def folded(name: str) -> str:
    """A target as written, as RAPID compares names: blanks dropped, case folded."""
    return re.sub(r"\s", "", name).casefold()


def _same(a: str, b: str) -> bool:
    """Two targets as written are the same (RAPID names are case-insensitive)."""
    return folded(a) == folded(b)


#: A comment line that names the operation below it: `! name`, one word.
_NAME_COMMENT = re.compile(r"^\s*!\s*([A-Za-z][\w-]*)\s*$")


def _comment_name(module: RapidModule, line: int) -> str | None:
    """The name a comment line `! name` (one word) right above line `line` gives, or None."""
    lines = module.text.splitlines()
    if not 2 <= line <= len(lines) + 1:
        return None
    found = _NAME_COMMENT.match(lines[line - 2])
    return None if found is None else found.group(1)


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
    data = find_wobj(module, wobj)
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
        touch = TouchOperation(
            m.target,
            previous.T_wobj_tcp,
            m.T_wobj_tcp,
            m.speed,
            m.line,
            previous.target,
            _comment_name(module, previous.line),
        )
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
    before = _move_before(module, touch_move)
    first = before if before is not None and _same(before.target, approach) else touch_move
    return TouchOperation(
        touch_move.target,
        T_approach,
        touch_move.T_wobj_tcp,
        touch_move.speed,
        touch_move.line,
        approach,
        _comment_name(module, first.line),
    )


def _move_before(module: RapidModule, move: Move) -> Move | None:
    """The move of the module just before `move` in the same routine, or None."""
    index = next(i for i, m in enumerate(module.moves) if m is move)
    before = module.moves[index - 1] if index > 0 else None
    return before if before is not None and before.routine == move.routine else None
