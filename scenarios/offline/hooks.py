"""What a stage tells the run while it moves the cell: a moment worth recording, a move, a
line of progress, and a check of its own that spoke.

The stages see the real cell only through the controller. The run (the runner) may want to
record the truth at those moments (the evaluator) or show the cell as it moved (the rerun
recording); it passes a `StageHooks` whose methods the stages call. The stages never learn
what the hooks do.
"""

from __future__ import annotations

from typing import Protocol

from scenarios.results.beam import Commissioning
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.verification_result import TcpCheck


class StageHooks(Protocol):
    """Callbacks of a stage into its run."""

    def moment(self, name: str, tool: str) -> None:
        """The program reached a moment named `name` with `tool` in hand (a touch, a pick)."""

    def moved(self, what: str) -> None:
        """The arm or the table moved (`what`: e.g. "tool change", "approach", "view")."""

    def say(self, message: str) -> None:
        """A line of the stage's progress."""

    def detect(self, code: str, message: str, action: str) -> None:
        """A check of the stage's own spoke (`code`), saw `message` and did `action`."""

    def checked(self, check: TcpCheck) -> None:
        """A tool was checked at the beam (every check, as it is made)."""

    def budgeted(self, budget: ErrorBudget) -> None:
        """The error budget of the targets was made, before the first touch."""

    def commissioning(self) -> Commissioning | None:
        """The cell's commissioning record (its tools' reference readings at the beam) for
        the arm's model the controller moves with now; None if the cell has none."""
