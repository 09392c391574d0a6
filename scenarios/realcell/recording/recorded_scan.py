"""The scan in the recording: the laser's rays as they really went, and the measured points
building up line by line and pass by pass.

Rays: witnessed at every laser line (calibration and scan alike), drawn from the laser's
true origin along its true rays to the measured range, so they end on the surface they hit
(to the laser's noise); cleared when the laser stops reading. Points: as measured, in the
table frame the cell model believes, drawn on the table: the current line, then each
finished pass as an entity of its own.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from scenarios.offline.scan_passes import ScanData
from scenarios.realcell.recording.stream import Stream

#: Rays drawn per laser line (evenly across its returns).
RAYS_PER_LINE = 5
#: A pause in the laser's lines longer than this [s] clears the rays.
GAP_S = 0.1
ON_OBJECT = (250, 200, 60, 255)
CLUTTER = (140, 140, 140, 255)


class LaserRays:
    """A witness of the laser: its rays per line, buffered, sent in one column."""

    def __init__(
        self, path: str = "world/laser/rays", colour: tuple[int, int, int] = (255, 70, 40)
    ) -> None:
        self.path = path
        self.colour = colour
        self._times: list[float] = []
        self._strips: list[np.ndarray] = []

    def sample(
        self, time_s: float, origin: np.ndarray, directions: np.ndarray, ranges: np.ndarray
    ) -> None:
        """One line: origin (3,), ray directions (n, 3), measured ranges (n,) (NaN: none)."""
        hit = np.flatnonzero(np.isfinite(ranges))
        if len(hit) > RAYS_PER_LINE:
            hit = hit[np.linspace(0, len(hit) - 1, RAYS_PER_LINE).round().astype(int)]
        ends = origin + ranges[hit, None] * directions[hit]
        strips = np.empty((len(hit), 2, 3))
        strips[:, 0], strips[:, 1] = origin, ends
        self._times.append(time_s)
        self._strips.append(strips)

    def flush(self, stream: Stream) -> None:
        if not self._times:
            return
        times, strips = [], []
        for k, t in enumerate(self._times):
            times.append(t)
            strips.append(self._strips[k])
            later = self._times[k + 1] if k + 1 < len(self._times) else np.inf
            if later - t > GAP_S:  # the laser stopped reading: no rays until it reads again
                times.append(t + GAP_S / 2)
                strips.append(np.empty((0, 2, 3)))
        lengths = [len(s) for s in strips]
        flat = [s for block in strips for s in block]
        stream.columns(
            self.path,
            np.asarray(times),
            rr.LineStrips3D.columns(strips=flat).partition(lengths),
        )
        stream.static(self.path, rr.LineStrips3D.from_fields(colors=[self.colour], radii=0.0004))
        self._times.clear()
        self._strips.clear()


def _shown(on_object: np.ndarray, every: int) -> np.ndarray:
    """Which points are drawn: every object point, every `every`-th of the rest."""
    rest = np.flatnonzero(~on_object)
    shown = on_object.copy()
    shown[rest[::every]] = True
    return shown


def log_scan(stream: Stream, scan: ScanData, on_object: np.ndarray, path: str) -> None:
    """The measured points (table frame) under `path`: `line` the current line (cleared
    after the last; every other point), `passes/pNN` each pass from its end on (every object
    point, every fourth of the rest); on the object yellow, the rest grey."""
    order = np.argsort(scan.line_index, kind="stable")
    line_of_point = scan.line_index[order]
    points = scan.points_table[order]
    on = on_object[order]
    colors = np.where(on[:, None], ON_OBJECT, CLUTTER).astype(np.uint8)
    drawn = np.zeros(len(points), dtype=bool)
    drawn[::2] = True
    per_line = np.bincount(line_of_point[drawn], minlength=scan.lines)
    times = np.append(scan.line_times_s, scan.line_times_s[-1] + GAP_S / 2)
    stream.columns(
        f"{path}/line",
        times,
        rr.Points3D.columns(positions=points[drawn], colors=colors[drawn])
        .partition([*per_line.tolist(), 0]),
    )  # fmt: skip
    stream.static(f"{path}/line", rr.Points3D.from_fields(radii=0.0006))
    shown = _shown(on, 4)
    for k in np.unique(scan.line_pass):
        lines = np.flatnonzero(scan.line_pass == k)
        mine = np.isin(line_of_point, lines) & shown
        stream.at(sim_time=float(scan.line_times_s[lines].max()))
        stream.log(
            f"{path}/passes/p{int(k):02d}",
            rr.Points3D(points[mine], colors=colors[mine], radii=0.0005),
        )
