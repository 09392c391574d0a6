"""A point laser on the controller's analog input, as the client reads it. The helper module
TcHelper copies the input aiLaserRange [mm] into the EGM packets (tcToSensor{2}) at each of
the input's changes, and counts the copies (tcToSensor{3}). `AnalogLaser` hands each packet's
reading over as a one-ray profile: stamped with the controller's time of the packet, and
numbered by that count, so a reading that several packets carry is one reading
(scenarios.irc5.profile_alignment keeps its first packet's).

A reading whose first packet may have been lost on the way (a gap in the packets' sequence
numbers, across which the count rose by less than one a packet) cannot be paired with its
pose: it could have come in the lost packet, a control period earlier. Every packet that
carries it hands it over as no return (the stream goes on, and gives no point).

The reading travels in the controller's own clock: there is no offset between clocks to
measure. What remains is the latency from the surface's distance to the input's change (the
sensor's response, its output's filter, the I/O system's update), which the calibration
identifies as it does a line profiler's (scenarios.offline.laser_latency).
"""

from __future__ import annotations

import numpy as np

from cell.layout import LaserConfig
from cell.profile_frames import Profile
from scenarios.irc5.egm_feedback import EgmFeedback, Feedback
from scenarios.irc5.line_profiler import LineProfiler, ProfileSink


class AnalogLaser(LineProfiler):
    """The point laser of data sheet `laser` (one ray; its measuring range: a reading outside
    it is no return) on the controller's input, as the EGM stream `feedback` carries it."""

    controller_clock = True

    def __init__(self, feedback: EgmFeedback, laser: LaserConfig) -> None:
        if laser.n_rays != 1:
            raise ValueError(f"an analog laser has one ray, not {laser.n_rays}")
        self.feedback = feedback
        self.range_m = (laser.range_min_m, laser.range_max_m)
        self._sink: ProfileSink | None = None
        self._last: tuple[int, int] | None = None  # the last packet's (seqno, count)
        self._unpaired: int | None = None  # the count of a reading that reads as no return

    def start(self, sink: ProfileSink) -> None:
        self._sink = sink
        self.feedback.listeners.append(self._take)

    def _take(self, sample: Feedback) -> None:
        if self._sink is None or sample.laser_mm is None or sample.laser_reads is None:
            return  # the stream carries no laser: a helper module without it
        count, last = sample.laser_reads, self._last
        self._last = (sample.seqno, count)
        if last is not None and count != last[1]:
            gap, rose = sample.seqno - last[0], count - last[1]
            self._unpaired = count if gap > 1 and rose < gap else None
        unpaired = count == self._unpaired
        d = np.array([np.nan]) if unpaired else self.distances(sample.laser_mm)
        self._sink(Profile(count, sample.time_s, d))

    def distances(self, laser_mm: float) -> np.ndarray:
        """The one ray's distance (1,) [m] of an input's value [mm]: NaN outside the range."""
        d = laser_mm * 1e-3
        low, high = self.range_m
        return np.array([d if low <= d <= high else np.nan])

    def stop(self) -> None:
        self._sink = None
        if self._take in self.feedback.listeners:
            self.feedback.listeners.remove(self._take)
