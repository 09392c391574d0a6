"""What a cell job's runner keeps of its run as it goes: the stage it is in and when each
began (on the controller's clock), every line of progress, and the stages' own checks that
spoke. The stages reach it through their hooks (scenarios.offline.hooks.StageHooks); the
evaluator and the stage tracker hear each stage as it begins."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from cell import Controller, ControllerEvent
from scenarios.jobs.stage_tracker import SETUP, StageTracker
from scenarios.realcell.cell_log import CellLog
from scenarios.realcell.evaluation import Evaluator
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.events import SupervisionEvent
from scenarios.results.verification_result import TcpCheck

Progress = Callable[[str], None]


class _HearsStages(Protocol):
    def enter(self, name: str) -> None: ...


class RunLog:
    """The run's stages, progress and checks: `say` prints a line (and, with a recording,
    logs it there too), `enter` begins a stage, `detect` records a stage's check that spoke,
    and the controller's supervision events are said as warnings of the stage they came in."""

    def __init__(
        self,
        controller: Controller,
        evaluator: Evaluator | None,
        cell_log: CellLog,
        progress: Progress,
        tracker: StageTracker | None = None,
        recording: Any | None = None,
    ) -> None:
        self._controller = controller
        hear = (evaluator, tracker)
        self._hear: tuple[_HearsStages, ...] = tuple(h for h in hear if h is not None)
        self._cell_log = cell_log
        self._progress = progress
        self._recording = recording
        self.stage = SETUP
        self.transitions: list[tuple[float, str]] = [(0.0, SETUP)]
        #: The stages' own checks that spoke.
        self.checks: list[SupervisionEvent] = []
        #: Every tool checked at the beam, in order, whatever happened next.
        self.tool_checks: list[TcpCheck] = []
        #: The targets' error budget, once made.
        self.budget: ErrorBudget | None = None
        controller.on_event = self._event

    def say(self, message: str) -> None:
        """A line of the run's progress (and of the recording's log, if there is one)."""
        self._progress(message)
        if self._recording is not None:
            self._cell_log.say(message)

    def enter(self, name: str) -> None:
        """The run begins the stage `name`, now."""
        self.stage = name
        self.transitions.append((self._controller.time_s, name))
        for listener in reversed(self._hear):
            listener.enter(name)

    def detect(self, code: str, message: str, action: str) -> None:
        """A stage's own check `code` spoke: it saw `message` and did `action`."""
        self.say(f"warning: {self.stage}: {message}; {action}")
        self.checks.append(
            SupervisionEvent(self.stage, self._controller.time_s, code, message, action)
        )

    def checked(self, check: TcpCheck) -> None:
        """A tool was checked at the beam: kept, and shown in the recording."""
        self.tool_checks.append(check)
        if self._recording is not None:
            self._recording.log_tool_check(self._controller.time_s, check)

    def budgeted(self, budget: ErrorBudget) -> None:
        """The targets' error budget was made: kept, and shown in the recording."""
        self.budget = budget
        if self._recording is not None:
            self._recording.log_budget(self._controller.time_s, budget)

    def stage_at(self, time_s: float) -> str:
        """The stage the run was in at `time_s` [s] of the controller's clock."""
        return next(name for t, name in reversed(self.transitions) if t <= time_s + 1e-9)

    def spoke(self) -> tuple[SupervisionEvent, ...]:
        """What the supervision and the checks saw, each in the stage it spoke in, in time
        order."""
        events = [
            SupervisionEvent(
                self.stage_at(e.time_s), e.time_s, e.code, e.message, e.action, e.reading, e.limit
            )
            for e in self._controller.events
        ]
        return tuple(sorted(events + self.checks, key=lambda d: d.time_s))

    def _event(self, event: ControllerEvent) -> None:
        self.say(f"warning: {self.stage}: {event.message}; {event.action}")
