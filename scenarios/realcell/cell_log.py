"""The jobs' hooks into the rerun recording while the cell moves: the true bodies now, the arm
followed through a move. Each is a no-op when the run has no recording, so the jobs call them
unconditionally (and rerun is not imported for a run without one).
"""

from __future__ import annotations

from typing import Any

from cell import Controller
from scenarios.realcell.evaluation import Evaluator


class CellLog:
    """Logs the real cell of one run into `recording` (a scenarios.recording.Recording, or
    None): the body poses come from the evaluator, the arm from the controller."""

    def __init__(self, recording: Any | None, controller: Controller, evaluator: Evaluator):
        self._recording = recording
        self._controller = controller
        self._evaluator = evaluator

    def bodies(self) -> None:
        """The true pose of every body of the cell, at the controller's time."""
        if self._recording is not None:
            self._recording.log_bodies(self._controller.time_s, self._evaluator.body_poses())

    def moved(self, what: str) -> None:
        """After a move (`what`, e.g. "tool change"): the arm's path since the last log,
        interpolated in joint space except through a tool change, then the bodies."""
        if self._recording is not None:
            c = self._controller
            self._recording.follow(
                c.time_s,
                c.read_joints(),
                c.kinematics,
                c.tool_in_hand,
                interpolate=what != "tool change",
            )
            self.bodies()
