"""The recording's stream: a rerun RecordingStream to a file (and to a live viewer), with
explicit times on every row.

Every timed log says its times (`at`): the stream forgets the previous ones first, so that a
row logged on one timeline never carries a stale index of another. Timelines: `sim_time`
(the cell's clock, a duration) and `icp` (the registration's steps, a sequence).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from scipy.spatial.transform import Rotation

SIM_TIME = "sim_time"
ICP = "icp"


def pose(T: np.ndarray) -> rr.Transform3D:
    """A (4, 4) transform as rerun's (its quaternion xyzw): the one conversion of the
    recording."""
    return rr.Transform3D(
        translation=T[:3, 3], quaternion=Rotation.from_matrix(T[:3, :3]).as_quat()
    )


class Stream:
    """Rows to `path` (written as `.<name>.partial`, moved into place by `close(True)`;
    no file if `to_file` is False) and, if `spawn`, to a live viewer that the file never
    waits for."""

    def __init__(
        self,
        path: Path,
        name: str,
        blueprint: rrb.Blueprint,
        spawn: bool = False,
        to_file: bool = True,
    ) -> None:
        self.path = Path(path)
        self._tmp = self.path.with_name(f".{self.path.name}.partial")
        first = rr.RecordingStream("twincell")
        self._file: rr.RecordingStream | None = None
        self._streams: list[rr.RecordingStream] = []
        if to_file:
            first.save(str(self._tmp), default_blueprint=blueprint)
            self._file = first
            self._streams.append(first)
        if spawn:
            viewer = rr.RecordingStream("twincell", recording_id=first.get_recording_id())
            viewer.spawn(default_blueprint=blueprint)
            self._streams.append(viewer)
        for s in self._streams:
            s.send_recording_name(name)
            s.set_log_time_enabled(False)  # the run's own clocks only: sim_time and icp

    def at(self, **times: float | int) -> None:
        """The times of the next rows: `sim_time=` seconds, `icp=` a step; nothing else."""
        for s in self._streams:
            s.reset_time()
            for timeline, value in times.items():
                if timeline == SIM_TIME:
                    s.set_time(timeline, duration=float(value))
                else:
                    s.set_time(timeline, sequence=int(value))

    def log(self, path: str, *archetypes: Any) -> None:
        """Rows at the times of the last `at`."""
        for s in self._streams:
            s.log(path, *archetypes)

    def static(self, path: str, *archetypes: Any) -> None:
        """Rows true at every time (geometry, legends)."""
        for s in self._streams:
            s.log(path, *archetypes, static=True)

    def send_blueprint(self, blueprint: rrb.Blueprint) -> None:
        """Replace the default layout (once the cell and the object are known)."""
        for s in self._streams:
            s.send_blueprint(blueprint, make_active=True, make_default=True)

    def columns(
        self,
        path: str,
        times: np.ndarray,
        columns: Iterable[Any],
        timeline: str = SIM_TIME,
    ) -> None:
        """Many rows at once: `times` (K,) on `timeline` [s for sim_time, steps for icp]."""
        index = (
            rr.TimeColumn(timeline, duration=np.asarray(times, dtype=float))
            if timeline == SIM_TIME
            else rr.TimeColumn(timeline, sequence=np.asarray(times, dtype=np.int64))
        )
        columns = list(columns)
        for s in self._streams:
            s.send_columns(path, indexes=[index], columns=columns)

    def close(self, keep: bool) -> None:
        """Flush and close; move the file into place if `keep`, else delete it. A live viewer
        gets 5 s to take the rest, then the run goes on without it."""
        for s in self._streams:
            if s is self._file:
                s.flush()
            else:
                with contextlib.suppress(RuntimeError):  # no viewer came up (no display)
                    s.flush(timeout_sec=5.0)
            s.disconnect()
        if self._file is None:
            return
        if keep:
            os.replace(self._tmp, self.path)
        else:
            self._tmp.unlink(missing_ok=True)
