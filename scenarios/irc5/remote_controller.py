"""The controller API over an ABB IRC5's own interfaces: `RemoteController` drives a real
controller, or `twincell serve` standing in for one, from another process.

- Moves: each is a RAPID module of one move (scenarios.irc5.move_modules) loaded over RWS,
  run from main and waited for (the overhead per move is a few requests: take the file, load,
  reset the pointer, start, poll). The controller plans and runs the move itself, under its
  own path planner and motion supervision; EGM guidance would bypass both.
- The encoders, the table and the controller's time: EGM's position stream (250 Hz), never an
  RWS poll. Nothing is commanded on a stream older than `max_age_s`.
- The tool changer: the `doToolLock` output, the `diToolLocked` and `aiToolNumber` inputs;
  picking and returning a tool are the controller API's own sequences of moves around them.
  The gripper, the screwer, the IR sensor and switching the motion supervision off:
  scenarios.irc5.remote_devices.
- The laser: a line profiler's own stream (scenarios.irc5.line_profiler), or a point laser
  on the controller's analog input that the EGM stream carries (scenarios.irc5.analog_laser),
  paired with the poses by time (scenarios.irc5.profile_alignment).
- A stop of the controller's supervision is read from its event log and raised as the
  SupervisionError it was; a move the controller refuses or fails is a ControllerRefusalError.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from cell.cell_errors import SupervisionError
from cell.controller import SETTLE_S, Controller, SupervisionLimits
from cell.kinematics import Kinematics
from cell.layout import LaserConfig
from cell.readings import LaserReading
from cell.robot_arm import Robot
from models.robot import TABLE_SPEED, beam_line
from scenarios.irc5.egm_feedback import EgmFeedback, Feedback, beam_of
from scenarios.irc5.line_profiler import ProfileBuffer, Received
from scenarios.irc5.link_errors import ControllerRefusalError, LinkError, NotOfferedError
from scenarios.irc5.motion_witness import MotionWitness
from scenarios.irc5.move_modules import MODULE, Tool, joint_move, joint_speed, linear_move
from scenarios.irc5.profile_alignment import readings
from scenarios.irc5.remote_devices import Devices
from scenarios.irc5.rws_link import RwsLink

#: How far the encoders may stand from a move's target when the controller says the program
#: ended, before the event log is asked why [rad]: at a stop point, and at a fly-by point
#: (the arm still on its way: the servo's lag at full speed).
IN_POSITION_RAD = 2.0e-3
FLY_BY_RAD = 0.05
#: How long after the arm stopped a profile made while it moved may still come [s] (the
#: sensor's and the controller's buffers and threads).
DRAIN_S = 0.05
#: The event log's codes of a stop: the motion supervision, the twin's supervision stops,
#: an execution error.
_COLLISION, _SUPERVISION, _EXECUTION = 50204, 89006, 89005


@dataclass(frozen=True)
class ClientSettings:
    """How the client works the link: the oldest position sample a command may rest on
    `max_age_s` [s], the longest a move's program may run `move_timeout_s` [s] (wall clock),
    the modules it loads (each has a main), unloaded if an earlier session left them, and the
    laser's latency from exposure to stamp [s] until the calibration identifies it (its data
    sheet's)."""

    max_age_s: float = 0.1
    move_timeout_s: float = 300.0
    own_modules: tuple[str, ...] = (MODULE,)
    laser_latency_s: float = 0.0


class RemoteController(Controller):
    """The controller at the other end of `link` (RWS), its position stream `feedback` (EGM)
    and the laser's `profiles` (None: no laser stream), with the cell's data sheets: the arm
    (`robot`, its nominal `kinematics`), the rack's place, the laser's rays; `settings` how
    the client waits and what it loads."""

    def __init__(
        self,
        link: RwsLink,
        feedback: EgmFeedback,
        profiles: ProfileBuffer | None,
        robot: Robot,
        kinematics: Kinematics,
        rack_xyz: tuple[float, float, float],
        laser: LaserConfig,
        limits: SupervisionLimits | None = None,
        settings: ClientSettings | None = None,
    ) -> None:
        super().__init__(robot, kinematics, rack_xyz, laser, limits)
        self.link, self.feedback, self.profiles = link, feedback, profiles
        self.devices = Devices(link, self._why_not_there)
        given = settings or ClientSettings()
        self.max_age_s, self.move_timeout_s = given.max_age_s, given.move_timeout_s
        own_modules = given.own_modules
        #: The sensor's clock minus the controller's [s], once measured.
        self.sensor_offset_s: float | None = None
        self._latency_s = given.laser_latency_s
        #: Hears each move's samples and each scan's lines (the run's recording), if set.
        self.witness: MotionWitness | None = None
        #: Wall time spent in the moves' programs and in the requests around them [s].
        self.moves = 0
        self.move_wall_s = 0.0
        link.ready()
        link.wait_stopped(30.0)
        link.clear(own_modules)
        first = feedback.after(time.monotonic() - 1.0, 5.0)
        self._q_command = first.q.copy()
        self._last_read_s = first.received_s
        self._tool = self.devices.tool_in_hand(self.tools)
        self._stopped_at = self._last_profile_s = time.monotonic()

    # -- state ------------------------------------------------------------------------------
    @property
    def tool_in_hand(self) -> str | None:
        return self._tool

    @property
    def time_s(self) -> float:
        return self.feedback.fresh(self.max_age_s).time_s

    def read_joints(self) -> np.ndarray:
        """The next encoder sample of the stream (each call a new one)."""
        self.feedback.fresh(self.max_age_s)
        sample = self.feedback.after(self._last_read_s, 1.0)
        self._last_read_s = sample.received_s
        return sample.q.copy()

    def table_position(self) -> float:
        table = self.feedback.fresh(self.max_age_s).table_m
        if table is None:
            raise LinkError("the controller's EGM feedback carries no external axis A (table)")
        return table

    # -- motion -----------------------------------------------------------------------------
    def _carried(self, T_flange_tcp: np.ndarray | None = None) -> Tool:
        """The tool a move carries: the one in hand (with `T_flange_tcp`, if a program's
        tooldata gives another TCP), or the flange."""
        name = self.tool_in_hand
        return Tool(name, self.T_flange_tcp() if T_flange_tcp is None else T_flange_tcp)

    def move_joints(
        self, q_target: np.ndarray, speed: float = 1.0, settle_s: float = SETTLE_S
    ) -> None:
        if not 0.0 < speed <= 1.0:
            raise ControllerRefusalError(f"speed must be a fraction in (0, 1], got {speed!r}")
        q1 = self.kinematics.check_limits(np.asarray(q_target, dtype=float))
        self._joint_move(q1, None, speed, settle_s)

    def _joint_move(
        self, q1: np.ndarray, table_m: float | None, speed: float, settle_s: float
    ) -> None:
        tool = self._carried()
        q0 = self.feedback.fresh(self.max_age_s).q
        speeds = joint_speed(
            self.nominal_kinematics, q0, q1, tool.T_flange_tcp, speed, self.robot.joint_speed
        )
        text = joint_move(q1, table_m, speeds, settle_s, tool, self.devices.supervised)
        end = self._run(text, f"MoveAbsJ to [{', '.join(f'{v:.4f}' for v in q1)}] rad")
        self._q_command = q1.copy()
        if np.max(np.abs(end.q - q1)) > _window(settle_s):
            self._why_not_there("the joint move")
        if table_m is not None and (end.table_m is None or abs(end.table_m - table_m) > 1e-3):
            self._why_not_there("the table's move")

    def solve_ik(self, T_base_tcp: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        seed = self._q_command if q_seed is None else q_seed
        return self.kinematics.solve(T_base_tcp, seed, self.T_flange_tcp())

    def reachable(self, T_base_tcp: np.ndarray) -> bool:
        return self.kinematics.reachable(T_base_tcp, self._q_command, self.T_flange_tcp())

    def move_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.2,
        angular_speed_rad_s: float = 1.0,
        settle_s: float = SETTLE_S,
        T_flange_tcp: np.ndarray | None = None,
    ) -> None:
        self._linear(T_base_tcp, speed_m_s, angular_speed_rad_s, settle_s, T_flange_tcp)

    def _linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float,
        angular_speed_rad_s: float,
        settle_s: float,
        T_flange_tcp: np.ndarray | None = None,
    ) -> Feedback:
        """A straight move of the TCP to T_base_tcp (4, 4): the joints there solved with the
        arm the controller moves with, the target written for the controller's nominal arm."""
        tool = self._carried(T_flange_tcp)
        q_end = self.kinematics.solve(T_base_tcp, self._q_command, tool.T_flange_tcp)
        speeds = (speed_m_s, angular_speed_rad_s)
        text = linear_move(self.nominal_kinematics, q_end, tool, *speeds, settle_s,
                           supervised=self.devices.supervised)  # fmt: skip
        end = self._run(text, "MoveL")
        self._q_command = q_end
        if np.max(np.abs(end.q - q_end)) > _window(settle_s):
            self._why_not_there("the straight move")
        return end

    def move_table(
        self, position_m: float, speed_m_s: float = TABLE_SPEED, settle_s: float = SETTLE_S
    ) -> None:
        self._joint_move(self._q_command, float(position_m), 1.0, settle_s)

    def scan_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.05,
        period_s: float = 0.01,
        settle_s: float = SETTLE_S,
    ) -> list[LaserReading]:
        """The straight move as a fly-by move (the scan ends where the motion ends), the
        profiles that came while it ran paired with the poses by the sensor's clock, set
        against the controller's while the arm stands just before and again just after (a
        clock that drifts is followed linearly between). The profiles come at the sensor's
        own rate, which `period_s` [s] should be (see `_thinned`)."""
        buffer = self._laser_buffer()
        before = self._standing_profile(buffer)
        offset0 = self._offset()
        t0 = time.monotonic()
        end = self._linear(T_base_tcp, speed_m_s, 1.0, 0.0)
        buffer.until(end.time_s + offset0, 5.0)  # the profiles made while moving have all come
        after = self._standing_profile(buffer, since=time.monotonic())
        offsets = ((before.profile.stamp_s, offset0), (after.profile.stamp_s, self._offset()))
        found = readings(buffer.since(t0), self.feedback.since(t0 - 0.1), offsets, self._latency_s)
        started_s = before.profile.stamp_s - offset0
        moving = [r for r in found if started_s + 1e-6 < r.time_s <= end.time_s + 1e-6]
        lines = _thinned(moving, period_s)
        if self.witness is not None:
            self.witness.lines(lines)
        return lines

    @property
    def laser_latency_s(self) -> float:
        return self._latency_s

    def set_laser_latency(self, latency_s: float) -> None:
        if not abs(latency_s) <= 0.5:
            raise ValueError(f"the laser's latency {latency_s!r} s: give -0.5 to 0.5 s")
        self._latency_s = float(latency_s)

    def read_laser(self) -> LaserReading:
        """The next profile, with the encoders at its instant (standing: whatever its latency)."""
        buffer = self._laser_buffer()
        came = self._standing_profile(buffer)
        found = readings([came], self.feedback.since(came.received_s - 0.2), self._offset())
        if not found:
            raise LinkError("a laser profile came without a position sample at its time")
        return found[0]

    def _standing_profile(self, buffer: ProfileBuffer, since: float = 0.0) -> Received:
        """The next profile made while the arm stands (that came after `since`, the client's
        monotonic clock [s]), with the sensor's clock set by it against the controller's: its
        stamp less the newest position sample's time (nothing for a sensor the controller
        stamps). Profiles made while the arm moved may still be on their way for DRAIN_S after
        it stopped."""
        self.feedback.fresh(self.max_age_s)
        drained = self._stopped_at + DRAIN_S
        if (wait := drained - time.monotonic()) > 0.0:
            time.sleep(wait)
        came = buffer.after(max(drained, self._last_profile_s, since), 2.0)
        sample = self.feedback.after(came.received_s, 1.0)
        self._last_profile_s = came.received_s
        clocked = buffer.sensor.controller_clock  # stamped by the controller: no offset
        self.sensor_offset_s = 0.0 if clocked else came.profile.stamp_s - sample.time_s
        return came

    def _offset(self) -> float:
        if self.sensor_offset_s is None:
            raise LinkError("the laser's clock has not been set against the controller's")
        return self.sensor_offset_s

    def _laser_buffer(self) -> ProfileBuffer:
        self._require("laser")
        if self.profiles is None:
            raise NotOfferedError("this client was given no laser profile stream (profiles)")
        return self.profiles

    # -- named stops and whole programs -----------------------------------------------------
    def stop_named(self, robtarget: str) -> None:
        """A stop point where the arm stands, its target named `robtarget` in the program the
        controller runs (what watches the controller's programs sees a touch by its name)."""
        tool, supervised = self._carried(), self.devices.supervised
        text = linear_move(self.nominal_kinematics, self._q_command, tool, 0.01, 0.1, SETTLE_S,
                           robtarget, supervised)  # fmt: skip
        self._run(text, f"the stop at {robtarget}")

    def run_program(self, module: str, text: str) -> None:
        """Run a whole RAPID module (`module`, its `text`) from main to its end, as the
        controller plans and runs it; the client's own moves start from where it ends."""
        end = self._run(text, f"the program {module}", module)
        self._q_command = end.q.copy()
        self._tool = self.devices.tool_in_hand(self.tools)

    # -- the program runs and their stops ---------------------------------------------------
    def _run(self, text: str, what: str, module: str = MODULE) -> Feedback:
        """Run a move's module to its end; the first position sample after it."""
        self.feedback.fresh(self.max_age_s)  # never a command on a stale reading
        t0 = time.perf_counter()
        since = time.monotonic()

        def ended(wait_s: float) -> bool:  # the stream says RAPID ran, then stopped
            return self.feedback.stopped_after_running(since, wait_s)

        try:
            self.link.run_module(module, text, self.move_timeout_s, ended)
        except ControllerRefusalError as exc:
            raise ControllerRefusalError(f"{what}: {exc}") from None
        stopped = time.monotonic()
        end = self.feedback.after(stopped, 1.0)
        while end.rapid_running:
            end = self.feedback.after(end.received_s, 1.0)
        self._last_read_s = end.received_s
        self._stopped_at = stopped
        self.moves += 1
        self.move_wall_s += time.perf_counter() - t0
        if self.witness is not None:
            self.witness.moved(self.feedback.since(since - 0.05), self._tool)
        return end

    def _why_not_there(self, what: str) -> NoReturn:
        """The arm did not end where it was sent: the event log's stop, raised as it was."""
        for entry in reversed(self.link.events()):
            if entry.code == _COLLISION:
                raise SupervisionError("collision", entry.desc)
            if entry.code == _SUPERVISION:
                code, _, message = entry.desc.partition(": ")
                raise SupervisionError(code if message else "supervision", message or code)
            if entry.code == _EXECUTION:
                raise ControllerRefusalError(f"{what} failed on the controller: {entry.desc}")
            if entry.code == 10007:  # the program's start: nothing stopped it
                break
        raise ControllerRefusalError(
            f"{what} did not end as asked, and the controller's event log says nothing of it"
        )

    # -- the tool changer -------------------------------------------------------------------
    def lock(self) -> str:
        self._set_lock(1)
        if self._tool is None:
            raise ControllerRefusalError("the tool changer locked, but aiToolNumber names no tool")
        return self._tool

    def unlock(self) -> str:
        held = self._tool
        if held is None:
            raise ControllerRefusalError("no tool is locked on the flange: nothing to release")
        self._set_lock(0)
        return held

    def _set_lock(self, value: int) -> None:
        """Set doToolLock and wait for diToolLocked to follow (a RAPID WaitDI \\MaxTime)."""
        self.feedback.fresh(self.max_age_s)
        self.devices.set_lock(value)
        self._tool = self.devices.tool_in_hand(self.tools)
        self._last_read_s = time.monotonic()
        if self.witness is not None:
            self.witness.moved([self.feedback.fresh(self.max_age_s)], self._tool)

    # -- what this client does not offer ----------------------------------------------------
    @property
    def beam_line_base(self) -> tuple[np.ndarray, np.ndarray]:
        a, b = beam_line(self._rack_xyz)
        return np.array(a, dtype=float), np.array(b, dtype=float)

    def sweep_beam(
        self, T_base_tcp: np.ndarray, speed_m_s: float = 0.01, settle_s: float = SETTLE_S
    ) -> list[tuple[np.ndarray, bool]]:
        """The straight move, the beam read with the encoders in every position sample while
        the arm moved (one per control period: 4 ms)."""
        start = self.feedback.fresh(self.max_age_s)
        t0 = time.monotonic()
        end = self._linear(T_base_tcp, speed_m_s, 1.0, 0.0)
        seen: dict[float, Feedback] = {}
        for sample in self.feedback.since(t0):
            if start.time_s < sample.time_s <= end.time_s:
                seen.setdefault(sample.time_s, sample)
        return [(s.q.copy(), beam_of(s)) for _t, s in sorted(seen.items())]

    def read_beam(self) -> bool:
        return beam_of(self.feedback.fresh(self.max_age_s))

    def servo(self, q_ref: np.ndarray, period_s: float) -> None:
        raise NotOfferedError("streamed joint references (servo): send them with EGM directly")

    def pace(self, clock: Callable[[float], str | None] | None) -> None:
        if clock is not None:
            raise NotOfferedError("a remote controller's time runs by its own clock (pace)")

    # -- the devices on the controller's I/O (scenarios.irc5.remote_devices) ---------------
    def supervision_off(self) -> AbstractContextManager[None]:
        return self.devices.supervision_off()

    def _device(self, tool: str) -> Devices:
        """The devices, with `tool` in hand and the position stream fresh."""
        self._require(tool)
        self.feedback.fresh(self.max_age_s)
        return self.devices

    def set_gripper(self, opening_m: float) -> None:
        self._device("gripper").set_gripper(opening_m)

    def spin_screwer(self, rad_s: float, seconds: float) -> None:
        self._device("screwer").spin_screwer(rad_s, seconds)

    def read_ir(self) -> float | None:
        return self._device("ir").read_ir()

    def link_summary(self) -> str:
        """What the link carried: moves and their wall time, requests, samples and profiles
        received and lost."""
        feedback, link = self.feedback, self.link
        text = (
            f"{self.moves} moves in {self.move_wall_s:.1f} s of wall time, "
            f"{link.requests} RWS requests ({link.request_s:.1f} s), EGM {feedback.received} "
            f"samples ({feedback.lost} lost)"
        )
        if self.profiles is not None:
            text += f", {self.profiles.received} laser profiles ({self.profiles.lost} lost)"
        return text

    def close(self) -> None:
        """Close the streams and the HTTP session (the controller keeps running)."""
        if self.profiles is not None:
            self.profiles.close()
        self.feedback.close()
        self.link.close()


def _window(settle_s: float) -> float:
    """The in-position window of a move [rad]: a stop point's if it settles, else fly-by's."""
    return IN_POSITION_RAD if settle_s > 0.0 else FLY_BY_RAD


def _thinned(found: list[LaserReading], period_s: float) -> list[LaserReading]:
    """The sensor's own profiles, less any that come sooner than half of `period_s` [s] after
    the one before (a sensor much faster than the scan was planned for)."""
    out: list[LaserReading] = []
    for reading in found:
        if not out or reading.time_s - out[-1].time_s >= 0.5 * period_s:
            out.append(reading)
    return out
