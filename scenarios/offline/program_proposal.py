"""A change to propose where the virtual cell refuses a user's program: each refused touch
moved the least that lets its moves pass, and proposed only if the whole program then
passes. A touch that goes into the object is moved back along the tool's axis by how deep
it went and a millimetre more (then a millimetre at a time); any other refusal (a collision
on the way, a joint limit, a singularity, out of reach) turns the touch and its approach
about the tool's axis, the smallest turn first. A program written for the virtual cell
keeps its poses, so the proposal is said as the poses to write, in the work object's frame
as RAPID writes them.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from scenarios.offline.program_plan import spun
from scenarios.program.program_types import Operation
from scenarios.rapid.oframe import pose_text

#: The turns tried where something does not pass, smallest first [deg]: of a refused touch
#: about the tool's axis here, of the part on the table in the reach and authoring proposals.
TURNS_DEG = (30.0, -30.0, 60.0, -60.0, 90.0, -90.0, 120.0, -120.0, 150.0, -150.0, 180.0)
#: Further back-offs tried beyond the depth a touch went in [m].
BACK_OFFS_M = (0.001, 0.002, 0.003)
_DEEP = re.compile(r"touches \w+ \((\d+(?:\.\d+)?) mm deep\)")

#: The problems of a program's check by operation name: each problem's detail.
Findings = dict[str, list[str]]


@dataclass(frozen=True)
class Change:
    """What is proposed for one touch: how it is said ("move it back 3.0 mm along the tool's
    axis") and the operation so changed."""

    said: str
    operation: Operation


@dataclass(frozen=True)
class ProgramProposal:
    """The changes (by touch name) that let the program pass, and its operations so
    changed."""

    changes: dict[str, Change]
    operations: tuple[Operation, ...]

    def text(self) -> str:
        """The proposal in one line: per touch the change and the poses to write."""
        said = []
        for name, change in self.changes.items():
            op = change.operation
            said.append(
                f"{name}: {change.said} (touch {pose_text(op.T_object_touch)}, approach "
                f"{pose_text(op.T_object_approach)} in its work object)"
            )
        return "; ".join(said)


def turned(operation: Operation, turn_deg: float) -> Operation:
    """`operation` with its touch and its approach turned `turn_deg` [deg] about their own z
    (the tool's axis)."""
    angle = np.radians(turn_deg)
    written = operation.T_object_approach_as_written
    return replace(
        operation,
        T_object_touch=spun(operation.T_object_touch, angle),
        T_object_approach_as_written=None if written is None else spun(written, angle),
    )


def backed_off(operation: Operation, distance_m: float) -> Operation:
    """`operation` with its touch `distance_m` [m] back along the tool's axis (its approach
    where it is)."""
    T = operation.T_object_touch.copy()
    T[:3, 3] -= distance_m * T[:3, 2]
    approach = operation.T_object_approach
    return replace(
        operation,
        T_object_touch=T,
        approach_m=float(np.linalg.norm(approach[:3, 3] - T[:3, 3])),
        T_object_approach_as_written=approach,
    )


def _changes(operation: Operation, details: list[str]) -> Iterator[Change]:
    """The changes tried for a refused touch, in order (see the module's docstring)."""
    depths = [float(m.group(1)) for d in details if (m := _DEEP.search(d))]
    if depths:
        deepest = max(depths) * 1e-3
        for extra in BACK_OFFS_M:
            d = np.ceil((deepest + extra) * 2e3) / 2e3  # to the half millimetre
            yield Change(
                f"move it back {d * 1e3:.1f} mm along the tool's axis", backed_off(operation, d)
            )
        return
    for turn in TURNS_DEG:
        yield Change(f"turn it {turn:+.0f} deg about the tool's axis", turned(operation, turn))


def propose_changes(
    operations: tuple[Operation, ...], refused: Callable[[tuple[Operation, ...]], Findings]
) -> ProgramProposal | None:
    """The changes of the touches `refused(operations)` finds problems with (by operation
    name; every operation where it cannot tell which) that let every operation pass, or None
    where no change of some touch does."""
    current = list(operations)
    changes: dict[str, Change] = {}
    findings = refused(tuple(current))
    for k, op in enumerate(operations):
        if op.name not in findings:
            continue
        for change in _changes(op, findings[op.name]):
            trial = [*current[:k], change.operation, *current[k + 1 :]]
            now = refused(tuple(trial))
            if op.name not in now:
                current, findings = trial, now
                changes[op.name] = change
                break
        else:
            return None
    return ProgramProposal(changes, tuple(current)) if not findings and changes else None
