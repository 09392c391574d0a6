"""What the client's moves tell a witness, such as the run's recording: after each move the
EGM samples it streamed and the tool in hand, after each scan its laser lines as paired with
the encoders. A witness only listens: what it does never changes a move."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from cell.readings import LaserReading
from scenarios.irc5.egm_feedback import Feedback


class MotionWitness(Protocol):
    def moved(self, samples: Sequence[Feedback], tool: str | None) -> None:
        """A move ended (or the tool changer worked): its samples in order, the tool now in
        hand."""

    def lines(self, readings: Sequence[LaserReading]) -> None:
        """A scan's lines, each with the encoders of its time."""
