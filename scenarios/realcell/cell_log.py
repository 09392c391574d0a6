"""The jobs' hooks into the rerun recording: the recording witnesses the real cell (every
body's true pose while it moves, every laser line), and hears the run's phases and
decisions at the controller's time. Each is a no-op when the run has no recording, so the
jobs call them unconditionally (and rerun is not imported for a run without one).
"""

from __future__ import annotations

from typing import Any

from cell import Controller
from scenarios.realcell.evaluation import Evaluator


class CellLog:
    """Connects `recording` (a scenarios.realcell.recording.Recording, or None) to the real
    cell of one run: the evaluator lets it witness the physics, the controller tells time.
    `object_name` is the real object's name in the cell, shown as `object_entity`."""

    def __init__(
        self,
        recording: Any | None,
        controller: Controller,
        evaluator: Evaluator | None,
        object_name: str = "object",
        object_entity: str = "object",
    ) -> None:
        self._recording = recording
        self._controller = controller
        if recording is not None and evaluator is not None:
            from models.robot.visuals import irb2400_visuals

            looks = irb2400_visuals() if controller.robot.name == "irb2400" else ()
            recording.start_cell(
                evaluator.mujoco_model, evaluator.mujoco_data, object_name, object_entity, looks
            )
            evaluator.watch(recording.bodies, recording.laser, recording.ir)

    def phase(self, name: str, detail: str = "") -> None:
        """A phase of the run begins now."""
        if self._recording is not None:
            self._recording.phase(self._controller.time_s, name, detail)

    def say(self, message: str) -> None:
        """A line of the run's progress, now."""
        if self._recording is not None:
            self._recording.text(self._controller.time_s, message)

    def moved(self, what: str) -> None:
        """After a move (`what`): a tool change is a decision worth a line of the log."""
        if self._recording is not None and what == "tool change":
            tool = self._controller.tool_in_hand
            self._recording.text(self._controller.time_s, f"tool change: {tool} in hand")
