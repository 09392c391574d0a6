"""What the served controller streams every control period, moving or standing: the EGM
feedback (the encoders, the flange, the table as external axis A, the controller's time, and
the helper module TcHelper's DataToSensor values) and, with the laser in hand, the laser's
readings at the sensor's rate: a line laser's profiles on their own stream
(cell.profile_frames), stamped in the sensor's clock; a point laser's distance on the
controller's analog input aiLaserRange, which TcHelper's trap copies into the EGM packets.

TcHelper's tcToSensor, as each packet carries it: {1} the TCP check's beam (1: broken), {2}
the point laser's distance [mm] (0: nothing in its range, or no point laser in hand), {3} how
many times the input's trap ran (a new reading; the trap runs when the input changes, at the
I/O system's update, here the laser's period).

The sensor's clock is the controller's time plus `clock_offset_s` (a sensor synchronised to
the plant's PTP master keeps Unix time; the controller counts from its own start), running
`drift_ppm` fast (a free-running quartz drifts by tens of ppm). The
twin's time stands still while nothing moves, and so do the stamps; the stream goes on.

The sensor's latency (`latency_s`, from a profile's exposure to its stamp: the camera's
readout and the profile's processing) stamps each profile made while the arm moves that much
after the instant it saw: its ranges are those of the arm's pose `latency_s` before its stamp.
While the arm stands, the twin's time stands still and a profile's stamp is its exposure's,
so the client's clock offset, set while standing, cannot take the latency up: only scans in
motion show it, which is how it is identified (scenarios.offline.laser_latency). A point
laser's input likewise shows, while the arm moves, the distance it saw `latency_s` before
(the sensor's response and its analog output's filter).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from cell import Controller
from cell.profile_frames import Profile
from scenarios.twin.egm import EgmServer
from scenarios.twin.profile_server import ProfileServer
from scenarios.twin.snapshot import Snapshot

#: The controller's control period [s].
PERIOD_S = 0.004
#: The longest latency a laser's stream may be given [s] (line profilers: 1 to 50 ms).
MAX_LATENCY_S = 0.5


@dataclass(frozen=True)
class LaserStream:
    """The laser's stream: its period [s] (of the controller's time while the arm moves;
    standing, of the wall clock's sped up as the twin's time runs), its clock's offset from
    the controller's [s], its drift against it [ppm], its latency from exposure to stamp [s],
    and whether it is a point laser on the analog input (`analog`: its readings ride the EGM
    packets in the controller's own clock, offset and drift do not apply)."""

    period_s: float = 0.01
    clock_offset_s: float = 0.0
    drift_ppm: float = 0.0
    latency_s: float = 0.0
    analog: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.latency_s <= MAX_LATENCY_S:
            raise ValueError(
                f"the laser's latency {self.latency_s!r} s: give 0 to {MAX_LATENCY_S:g} s"
            )


class SensorStreams:
    """The EGM feedback to `egm` (None: no EGM session) and the laser's profiles to
    `profiles` (None: no profile stream), of a twin whose time runs `speed` times the wall
    clock's."""

    def __init__(
        self,
        egm: EgmServer | None = None,
        profiles: ProfileServer | None = None,
        laser: LaserStream | None = None,
        speed: float = 1.0,
    ) -> None:
        self.egm = egm
        self.profiles = profiles
        self.laser = laser or LaserStream()
        self.speed = speed
        self._seqno = 0
        self._next_s: float | None = None
        self._idle_ticks = 0
        #: The analog input aiLaserRange [mm] and how many times TcHelper's trap copied it.
        self.laser_mm = 0.0
        self.trapped = 0
        self._seen: deque[tuple[float, float]] = deque()

    @property
    def streaming(self) -> bool:
        """Whether anything streams (the worker then ticks while standing)."""
        return (self.egm is not None and self.egm.active()) or self.profiles is not None

    def publish(
        self, cell: Controller, snap: Snapshot, motors_on: bool, running: bool, moving: bool
    ) -> None:
        """One control period of the streams: EGM feedback of `snap`, and a profile if one is
        due (`moving`: by the controller's time; standing: every period of the wall clock)."""
        if self.laser.analog:
            self._analog(cell, snap, moving)
        if self.egm is not None:
            to_sensor = (1.0 if snap.beam else 0.0, self.laser_mm, float(self.trapped))
            self.egm.feedback(snap, motors_on, running, to_sensor)
        if self.profiles is None or cell.tool_in_hand != "laser" or not self._due(snap, moving):
            return
        reading = cell.read_laser()
        self._seqno += 1
        laser = self.laser
        seen_s = reading.time_s + (laser.latency_s if moving else 0.0)
        stamp = seen_s * (1.0 + laser.drift_ppm * 1e-6) + laser.clock_offset_s
        self.profiles.send(Profile(self._seqno, stamp, reading.distances))

    def _analog(self, cell: Controller, snap: Snapshot, moving: bool) -> None:
        """The point laser's input at `snap`: the distance it saw `latency_s` before while the
        arm moves, its reading now while it stands; the trap runs where the input changed."""
        if cell.tool_in_hand != "laser":
            self._seen.clear()
            value = 0.0
        elif not self._due(snap, moving):
            return
        else:
            distance = float(cell.read_laser().distances[0])
            seen = distance * 1e3 if np.isfinite(distance) else 0.0
            if not moving:
                self._seen.clear()
                value = seen
            else:
                self._seen.append((snap.time_s, seen))
                value = self.laser_mm
                while self._seen and self._seen[0][0] <= snap.time_s - self.laser.latency_s + 1e-9:
                    value = self._seen.popleft()[1]
        if value != self.laser_mm:
            self.laser_mm = value
            self.trapped += 1

    def _due(self, snap: Snapshot, moving: bool) -> bool:
        period = self.laser.period_s
        if not moving:
            self._next_s = None
            self._idle_ticks += 1
            if self._idle_ticks * PERIOD_S * self.speed < period:
                return False
            self._idle_ticks = 0
            return True
        self._idle_ticks = 0
        if self._next_s is not None and snap.time_s + 1e-9 < self._next_s:
            return False
        # the first profile of a move, or one more than a period late, starts the schedule
        last = self._next_s
        behind = last is None or snap.time_s - last >= period
        self._next_s = (snap.time_s if last is None or behind else last) + period
        return True

    def close(self) -> None:
        if self.profiles is not None:
            self.profiles.close()
