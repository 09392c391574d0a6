"""The simulated real cell's controller: the controller API (cell.controller) on the physics.

It drives the simulation's servos, reads its encoders, laser, IR sensor and table axis, and
supervises the motion the way an industrial controller does (contact force, the lock sensor,
the load check, the table's in-position window, the encoders' second channel). The set-points
of a straight TCP move are cell.trajectory's (linear_trajectory); this runs them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import TypeVar

import numpy as np

from cell.cell_errors import (
    CellConfigError,
    JointLimitError,
    MotionHaltedError,
    SupervisionError,
)
from cell.controller import (
    SETTLE_S,
    Controller,
    SupervisionLimits,
)
from cell.irb2400_arm import irb2400
from cell.kinematics import Kinematics
from cell.readings import LaserReading
from cell.robot_arm import Robot
from cell.sim.devices import Encoders, TableAxis
from cell.sim.drives import Drives
from cell.sim.sensors import IRSensor, LaserScanner, LightBeam
from cell.sim.simulation import MotionStoppedError, Simulation
from cell.sim.supervision import ContactSensing
from cell.sim.toolchanger import ToolChanger
from cell.trajectory import joint_trajectory, linear_trajectory
from models.robot import FINGER_TRAVEL, RACK_POS, TABLE_SPEED, TABLE_TRAVEL, beam_line

Reading = TypeVar("Reading")
#: How much of its path the arm backs off after a supervision stop [s].
BACK_OFF_S = 0.3


@dataclass(frozen=True, eq=False)
class Devices:
    """The devices of the simulated cell its controller drives and reads: the joints'
    encoders, the table's axis, the laser scanner, the IR sensor, the arm's drives and the
    tool changer."""

    encoders: Encoders
    table: TableAxis
    laser: LaserScanner
    ir: IRSensor
    drives: Drives
    changer: ToolChanger


class SimController(Controller):
    """The controller of the simulated real cell."""

    def __init__(
        self,
        sim: Simulation,
        kinematics: Kinematics,
        devices: Devices,
        robot: Robot | None = None,
        rack_xyz: tuple[float, float, float] = RACK_POS,
        limits: SupervisionLimits | None = None,
        clock_start_utc: datetime | None = None,
    ) -> None:
        changer = devices.changer
        self._clock_start = clock_start_utc
        super().__init__(robot or irb2400(), kinematics, rack_xyz, devices.laser.config, limits)
        self._sim = sim
        self._contacts = ContactSensing(sim, lambda: changer.held)
        self._supervising = True
        self._beam = LightBeam(sim.model, *(np.array(p) for p in beam_line(rack_xyz)))
        sim.guard = self._guard
        self._encoders = devices.encoders
        self._table = devices.table
        self._laser = devices.laser
        self._ir = devices.ir
        self._drives = devices.drives
        self._changer = changer

    @property
    def tool_in_hand(self) -> str | None:
        return self._changer.held

    @property
    def time_s(self) -> float:
        return self._sim.time

    def clock_utc(self) -> datetime:
        """The cell's clock where its configuration starts one (`clock_start_utc`, the
        date and time at the simulation's start; a shift's jobs run on the shift's clock,
        not the computer's), advanced by the simulated time; else this computer's."""
        if self._clock_start is None:
            return super().clock_utc()
        return self._clock_start + timedelta(seconds=self._sim.time)

    def read_joints(self) -> np.ndarray:
        for attempt in range(2):
            a, b = self._encoders.read_channels()
            off = np.abs(a - b)
            joint = int(np.argmax(off))
            if off[joint] <= (limit_rad := self.limits.max_channel_difference_rad):
                return a
            message = f"joint {joint + 1}: the encoder's channels differ by {off[joint]:.4f} rad"
            action = "re-read" if attempt == 0 else "stopped"
            self._log("joint_plausibility", message, action, float(off[joint]), limit_rad)
        raise SupervisionError("joint_plausibility", f"{message}, twice")

    # -- motion -------------------------------------------------------------------------------
    def move_joints(
        self, q_target: np.ndarray, speed: float = 1.0, settle_s: float = SETTLE_S
    ) -> None:
        if not 0.0 < speed <= 1.0:
            raise CellConfigError(f"speed must be a fraction in (0, 1], got {speed!r}")
        q1 = self.kinematics.check_limits(q_target)
        sim = self._sim
        q, qd = joint_trajectory(self._drives.motor, q1, self._robot.joint_speed, sim.dt, speed)
        self._run(q, qd)
        sim.settle(settle_s)

    def servo(self, q_ref: np.ndarray, period_s: float) -> None:
        q1 = self.kinematics.check_limits(np.asarray(q_ref, dtype=float))
        sim, q0 = self._sim, self._drives.motor.copy()
        n = max(1, round(period_s / sim.dt))
        reach = self._robot.joint_speed * period_s
        step = np.clip(q1 - q0, -reach, reach)
        q = q0 + np.outer(np.arange(1, n + 1) / n, step)
        qd = np.broadcast_to(step / period_s, q.shape).copy()
        self._run(q, qd, new_move=False)

    def pace(self, clock: Callable[[float], str | None] | None) -> None:
        self._sim.clock = clock

    def solve_ik(self, T_base_tcp: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        seed = self._drives.motor if q_seed is None else q_seed
        return self.kinematics.solve(T_base_tcp, seed, self.T_flange_tcp())

    def reachable(self, T_base_tcp: np.ndarray) -> bool:
        return self.kinematics.reachable(T_base_tcp, self._drives.motor, self.T_flange_tcp())

    def move_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.2,
        angular_speed_rad_s: float = 1.0,
        settle_s: float = SETTLE_S,
        T_flange_tcp: np.ndarray | None = None,
    ) -> None:
        q, qd = self._linear_setpoints(T_base_tcp, speed_m_s, angular_speed_rad_s, T_flange_tcp)
        self._run(q, qd)
        self._sim.settle(settle_s)

    def scan_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.05,
        period_s: float = 0.01,
        settle_s: float = SETTLE_S,
    ) -> list[LaserReading]:
        self._require("laser")
        return self._read_along(T_base_tcp, speed_m_s, period_s, settle_s, self.read_laser)

    def sweep_beam(
        self, T_base_tcp: np.ndarray, speed_m_s: float = 0.01, settle_s: float = SETTLE_S
    ) -> list[tuple[np.ndarray, bool]]:
        return self._read_along(
            T_base_tcp,
            speed_m_s,
            self._sim.dt,
            settle_s,
            lambda: (self.read_joints(), self._beam.broken(self._sim.data)),
        )

    def _read_along(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float,
        period_s: float,
        settle_s: float,
        read: Callable[[], Reading],
    ) -> list[Reading]:
        """A straight TCP move, `read()` every `period_s` [s] while moving."""
        sim = self._sim
        every = max(1, round(period_s / sim.dt))
        q, qd = self._linear_setpoints(T_base_tcp, speed_m_s, 1.0)
        readings = self._run(q, qd, read, every)
        sim.settle(settle_s)
        return readings

    def read_beam(self) -> bool:
        return self._beam.broken(self._sim.data)

    @property
    def beam_line_base(self) -> tuple[np.ndarray, np.ndarray]:
        return self._beam.p_from.copy(), self._beam.p_to.copy()

    # -- supervision --------------------------------------------------------------------------
    def _guard(self) -> str | None:
        """The motion supervision, every few physics steps of a move."""
        if not self._supervising:
            return None
        force, body = self._contacts.external()
        if force > self.limits.max_contact_force_n:
            return f"collision: {force:.0f} N on {body}"
        return None

    @contextmanager
    def supervision_off(self) -> Iterator[None]:
        self._supervising = False
        try:
            yield
        finally:
            self._supervising = True

    def _run(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        read: Callable[[], Reading] | None = None,
        every: int = 1,
        new_move: bool = True,
    ) -> list[Reading]:
        """Run motor set-points (K, 6) under motion supervision, `read()` after every
        `every` steps (and the last) if given (`new_move`: see Drives.run): a stop holds the
        arm, backs it off along the path it came and raises SupervisionError; the clock's
        halt holds it where it is and raises MotionHaltedError."""
        try:
            return self._drives.run(q, qd, read=read, every=every, new_move=new_move)
        except MotionStoppedError as stop:
            if stop.halt:
                self._drives.hold()
                self._sim.settle(SETTLE_S)
                self._log("halted", str(stop), "stopped")
                raise MotionHaltedError(f"halted at t = {self.time_s:.2f} s: {stop}") from None
            done = q[: stop.steps]
            back = done[::-1][: max(2, round(BACK_OFF_S / self._sim.dt))]
            self._supervising = False
            clock = self._sim.clock
            if clock is not None:  # paced still, but a back-off is not halted
                self._sim.clock = lambda t: clock(t) and None
            try:
                self._drives.run(back, np.zeros_like(back))
                self._sim.settle(SETTLE_S)
            finally:
                self._supervising = True
                self._sim.clock = clock
            self._log("collision", str(stop), "stopped")
            raise SupervisionError(
                "collision",
                f"motion supervision stopped the arm at t = {self.time_s:.2f} s ({stop}); it "
                f"backed off {len(back) * self._sim.dt:.2f} s along its path",
            ) from None

    def _linear_setpoints(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float,
        angular_speed_rad_s: float,
        T_flange_tcp: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Motor set-points (K, 6) [rad] and velocities (K, 6) [rad/s] of a straight TCP
        line from the current set-point."""
        if not (speed_m_s > 0 and angular_speed_rad_s > 0):
            raise CellConfigError(
                f"speeds must be > 0, got {speed_m_s!r} m/s, {angular_speed_rad_s!r} rad/s"
            )
        T_base_tcp = np.asarray(T_base_tcp, dtype=float)
        T_tcp = self.T_flange_tcp() if T_flange_tcp is None else np.asarray(T_flange_tcp, float)
        return linear_trajectory(
            self.kinematics,
            self._drives.motor.copy(),
            T_base_tcp,
            T_tcp,
            speed_m_s,
            angular_speed_rad_s,
            self._robot.joint_speed,
            self._sim.dt,
        )

    # -- tool changer -------------------------------------------------------------------------
    def lock(self) -> str:
        for attempt in range(2):
            name = self._changer.lock()
            if self._changer.held is not None:
                break
            message = f"lock sensor: the {name} tool is not locked"
            if attempt == 0:
                self._log("lock_sensor", message, "retried")
                continue
            self._log("lock_sensor", message, "stopped")
            raise SupervisionError("lock_sensor", f"{message} after a retry")
        self._drives.hold()  # the arm now carries the tool
        self._check_load(name)
        return name

    def _check_load(self, tool: str) -> None:
        """The static load check: holding still, the motors' torques beyond what the payload
        model compensates [N m]."""
        self._sim.settle(0.2)
        torque = np.abs(self._sim.data.actuator_force[self._sim.arm_act])
        axis = int(np.argmax(torque))
        if torque[axis] > (limit_nm := self.limits.max_load_torque_nm):
            message = (
                f"load: axis {axis + 1} holds {torque[axis]:.1f} N m that the {tool} tool's "
                "tooldata does not explain (the tool is heavier than its tooldata)"
            )
            self._log("load", message, "stopped", float(torque[axis]), limit_nm)
            raise SupervisionError("load", message)

    def unlock(self) -> str:
        name = self._changer.unlock()
        self._drives.hold()
        return name

    def _q_seed(self) -> np.ndarray:
        return self._drives.motor

    # -- tools' actuators ---------------------------------------------------------------------
    def set_gripper(self, opening_m: float) -> None:
        self._require("gripper")
        if not 0.0 <= opening_m <= FINGER_TRAVEL:
            raise CellConfigError(
                f"finger opening must be in [0, {FINGER_TRAVEL}] m, got {opening_m!r}"
            )
        self._sim.data.ctrl[self._sim.finger_act] = opening_m
        self._sim.settle(0.3)

    def spin_screwer(self, rad_s: float, seconds: float) -> None:
        self._require("screwer")
        sim = self._sim
        sim.data.ctrl[sim.spindle_act] = rad_s
        sim.settle(seconds)
        sim.data.ctrl[sim.spindle_act] = 0.0

    # -- table --------------------------------------------------------------------------------
    def move_table(
        self, position_m: float, speed_m_s: float = TABLE_SPEED, settle_s: float = SETTLE_S
    ) -> None:
        lo, hi = TABLE_TRAVEL
        if not lo <= position_m <= hi:
            raise JointLimitError(
                f"table position {position_m!r} m is outside its travel [{lo}, {hi}] m"
            )
        if not 0.0 < speed_m_s <= TABLE_SPEED:
            raise CellConfigError(
                f"table speed must be in (0, {TABLE_SPEED}] m/s, got {speed_m_s!r}"
            )
        for attempt in range(2):
            try:
                self._table.move(position_m, speed_m_s, settle_s)
            except MotionStoppedError as stop:
                self._log("collision", str(stop), "stopped")
                raise SupervisionError(
                    "collision", f"motion supervision stopped the table ({stop})"
                ) from None
            off = self._table.read() - position_m
            if abs(off) <= (limit_m := self.limits.table_in_position_m):
                return
            message = f"table not in position: readout {off * 1e3:+.2f} mm from {position_m:g} m"
            action = "retried" if attempt == 0 else "stopped"
            self._log("table_in_position", message, action, float(abs(off)), limit_m)
        raise SupervisionError("table_in_position", f"{message} after a retry")

    def table_position(self) -> float:
        return self._table.read()

    # -- sensors ------------------------------------------------------------------------------
    def read_ir(self) -> float | None:
        self._require("ir")
        return self._ir.cast(self._sim.data)

    def read_laser(self) -> LaserReading:
        self._require("laser")
        sim = self._sim
        return LaserReading(
            distances=self._laser.cast(sim.data),
            q_measured=self.read_joints(),
            table_position_m=self._table.read(),
            time_s=sim.time,
        )
