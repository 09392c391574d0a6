"""The recording's cell for a run across the network: the job's process has no physics to
witness, so the cell is drawn as the job knows it. Its virtual cell (the nominal arm and
rack, the virtual model at its nominal pose, the calibration spheres) is posed by what the
controller streamed: the encoders and the table from each move's EGM samples, the tool the
changer reports; the laser's lines are drawn as the client paired them with the encoders.

`RemoteScene` is the controller's witness (scenarios.irc5.motion_witness.MotionWitness):
after each move it hears the move's samples, after each scan its lines.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from cell import LaserReading
from cell.virtual import VirtualCell
from models.robot.visuals import LinkVisual
from scenarios.irc5.egm_feedback import Feedback
from scenarios.realcell.recording import Recording

#: The laser's origin (3,) and rays (n, 3) in the base frame at joints q (6,) [rad].
LaserFrame = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

#: The recording's frame rate of the arm's motion [Hz of the controller's time] (the EGM
#: stream's 250 Hz thinned).
FRAME_RATE_HZ = 30.0


class RemoteScene:
    """The cell `cell` (a VirtualCell) in `recording` (scenarios.realcell.recording.Recording),
    its object named `object_name` shown as `object_entity`, the arm drawn with `visuals`;
    the laser's lines placed by `laser_frame(q)`: its origin (3,) and rays (n, 3) in the base
    frame at joints q."""

    def __init__(
        self,
        recording: Recording,
        cell: VirtualCell,
        object_name: str,
        object_entity: str,
        visuals: tuple[LinkVisual, ...] = (),
        laser_frame: LaserFrame | None = None,
    ) -> None:
        self._recording = recording
        self._cell = cell
        self._laser_frame = laser_frame
        self._last_s = -np.inf
        recording.start_cell(cell.model, cell.posed(), object_name, object_entity, visuals)

    def moved(self, samples: Sequence[Feedback], tool: str | None) -> None:
        """A move's EGM samples (in order), the tool in hand: the arm at FRAME_RATE_HZ of
        the controller's time, and where the move ended."""
        cell = self._cell
        if tool != cell.tool_in_hand:
            cell.set_tool(tool)
        for k, sample in enumerate(samples):
            last = k == len(samples) - 1
            if sample.time_s - self._last_s < 1.0 / FRAME_RATE_HZ and not last:
                continue
            if sample.time_s <= self._last_s:
                continue  # the controller's time stood still: nothing moved
            self._pose(sample)

    def _pose(self, sample: Feedback) -> None:
        cell = self._cell
        cell.set_joints(sample.q)
        if sample.table_m is not None:
            cell.set_table(sample.table_m)
        data = cell.posed()
        data.time = sample.time_s
        self._recording.bodies(data)
        self._last_s = sample.time_s

    def lines(self, readings: Sequence[LaserReading]) -> None:
        """A scan's laser lines, each with the cell posed as the encoders of its time put it
        (the move's frames were drawn already: these add the poses at the lines' times)."""
        if self._laser_frame is None or not readings:
            return
        cell = self._cell
        q_end, table_end = cell.q.copy(), cell.table_position_m
        for r in readings:
            cell.set_joints(r.q_measured)
            cell.set_table(r.table_position_m)
            data = cell.posed()
            data.time = r.time_s
            origin, rays = self._laser_frame(r.q_measured)
            self._recording.laser(data, origin, rays, r.distances)
        cell.set_joints(q_end)
        cell.set_table(table_end)
