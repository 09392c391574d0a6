"""What a stage is (`Stage`) and what it returns (`Outcome`).

A stage is an object with one method, `run(ctx)`, which reads the context (the controller
API, the virtual model, the planning settings and the job's state so far) and returns a
frozen outcome; the outcome says how it moves the state on (`advance`) and which stages, if
any, must run next, before the rest (`then`: the verification's re-scan). Whether a stage
is due at all is asked first (`due`), before the run enters it, so that a skipped stage
leaves no trace in the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from scenarios.stages.context import StageContext
from scenarios.stages.state import JobState


@dataclass(frozen=True)
class Outcome:
    """A stage's result. `advance` moves the job's state on; `then` names the stages that
    must run next, before the rest of the job's (none by default)."""

    def advance(self, state: JobState) -> JobState:
        return state

    def then(self) -> tuple[Stage, ...]:
        return ()


class Stage(Protocol):
    """One stage of a job: its `name` (the run's stage while it runs, as results.json and
    the fault injection know it) and `title` (a line for the recording's log)."""

    @property
    def name(self) -> str: ...

    @property
    def title(self) -> str: ...

    def due(self, ctx: StageContext) -> bool:
        """Whether the stage runs, given the job so far (`ctx.state`)."""
        ...

    def run(self, ctx: StageContext) -> Outcome:
        """Do the stage's work on the context (its `state` is the job so far)."""
        ...
