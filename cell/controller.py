"""The controller API: the only way planning code drives and reads the real cell.

It offers what a robot controller offers: joint and linear TCP moves, the tool changer, the
table axis, encoder, IR and laser readings, its event log. Kinematics is the NOMINAL model
(Pinocchio on the nominal robot-only MJCF) or the calibrated one it is given. `Controller` is
abstract: the simulated real cell implements it (cell.sim.sim_controller), and so would a real
controller's client. Nothing here can return the simulated truth (true kinematic parameters,
true poses, noise): that lives in `cell.sim`, for evaluators only.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from datetime import UTC, datetime

import numpy as np

from cell.cell_errors import CellConfigError, ToolChangerError, UnknownNameError
from cell.kinematics import Kinematics
from cell.laser import laser_points_base
from cell.layout import LaserConfig
from cell.readings import LaserReading
from cell.robot_arm import Robot
from models.robot import RACK_POS, SLOT_QUAT, TABLE_SPEED, TABLE_TOP_POS, TOOLS, slot_pos
from registration.rigid import make_T, quat_wxyz_to_R

_TOOL_SPECS = {t.name: t for t in TOOLS}
#: Default settle time after a move [s].
SETTLE_S = 0.3
#: Approach height above a rack slot for tool changes [m].
RACK_APPROACH_M = 0.12
#: How far towards the arm's base from above a slot a tool change starts and ends [m].
RACK_FRONT_M = 0.2


@dataclass(frozen=True)
class ControllerEvent:
    """An entry of the controller's event log: the time [s], the supervision that spoke
    (`code`: collision, lock_sensor, table_in_position, joint_plausibility, load), what it
    saw, and what the controller did (`action`: retried, re-read, stopped); the figure it
    read and the limit it held it to, in SI units (the channels' difference [rad], the
    table's offset [m], the holding torque [N m]), or None (a switch, a stop)."""

    time_s: float
    code: str
    message: str
    action: str
    reading: float | None = None
    limit: float | None = None


@dataclass(frozen=True)
class SupervisionLimits:
    """The supervision's thresholds: the external force that stops a move [N] (ABB's
    collision detection trips at a few tens of newtons at this arm's tool); how far a
    joint's two encoder channels may differ [rad] (their noise is a few hundredths of a
    milliradian); the table's in-position window [m]; the largest unexplained holding
    torque after a tool change [N m]."""

    max_contact_force_n: float = 40.0
    max_channel_difference_rad: float = 1.0e-3
    table_in_position_m: float = 2.0e-4
    max_load_torque_nm: float = 5.0


def nominal_T_base_slot(tool: str, rack_xyz: tuple[float, float, float] = RACK_POS) -> np.ndarray:
    """(4, 4) nominal pose of `tool`'s rack slot in the robot base frame, for the rack at
    `rack_xyz` [m] (its nominal place in the cell's layout)."""
    return make_T(
        quat_wxyz_to_R(np.array(SLOT_QUAT)), np.array(slot_pos(tool_index(tool), rack_xyz))
    )


def nominal_T_base_table(table_position_m: float) -> np.ndarray:
    """(4, 4) nominal pose of the table frame (top surface centre) in the robot base frame."""
    return make_T(np.eye(3), np.array(TABLE_TOP_POS) + np.array([0.0, table_position_m, 0.0]))


def tool_index(tool: str) -> int:
    """The rack slot of `tool`; an unknown name lists the tools."""
    for i, spec in enumerate(TOOLS):
        if spec.name == tool:
            return i
    raise UnknownNameError(
        f"unknown tool {tool!r}; available tools: {', '.join(t.name for t in TOOLS)}"
    )


def rack_above(T_slot: np.ndarray) -> np.ndarray:
    """(4, 4) a rack slot's pose `T_slot` raised by RACK_APPROACH_M."""
    T = T_slot.copy()
    T[2, 3] += RACK_APPROACH_M
    return T


def rack_front(T_slot: np.ndarray) -> np.ndarray:
    """(4, 4) above the slot and RACK_FRONT_M towards the arm's base, clear of the tools
    hanging in the rack: a joint move to or from the rack starts or ends there, so the tool
    in hand never sweeps through its neighbours."""
    T = rack_above(T_slot)
    towards = -T[:2, 3] / max(float(np.linalg.norm(T[:2, 3])), 1e-9)
    T[:2, 3] += RACK_FRONT_M * towards
    return T


class Controller(ABC):
    """Commands and readings of the cell, as a robot controller would offer them.

    What it holds is what a controller knows: the arm's data sheet (`robot`), the kinematics
    it moves with, the cell's layout (the rack's place), the supervision's limits, the
    laser's data sheet, and its event log.
    """

    def __init__(
        self,
        robot: Robot,
        kinematics: Kinematics,
        rack_xyz: tuple[float, float, float],
        laser: LaserConfig,
        limits: SupervisionLimits | None = None,
    ) -> None:
        self.limits = limits or SupervisionLimits()
        #: The controller's event log: every supervision that spoke, in order; `on_event`
        #: hears each as it is logged (a program's error handler, a run's progress).
        self.events: list[ControllerEvent] = []
        self.on_event: Callable[[ControllerEvent], None] | None = None
        self._robot = robot
        self._rack_xyz = rack_xyz
        self._nominal = kinematics
        self._kinematics = kinematics
        #: The laser's data sheet: its rays (N, 3) in its TCP frame, measuring range [m] and
        #: the largest incidence it returns from [rad]; its noise and errors are not told.
        self.laser_directions_tcp = laser.directions_tcp()
        self.laser_range_m = (laser.range_min_m, laser.range_max_m)
        self.laser_max_incidence_rad = laser.max_incidence_rad

    # -- what the controller knows --------------------------------------------------------
    @property
    def kinematics(self) -> Kinematics:
        """The arm's kinematics the controller moves with, for the tool in hand: the nominal
        arm, or the calibrated one given to `set_absolute_accuracy`."""
        return self._kinematics.for_tool(self.tool_in_hand)

    @property
    def nominal_kinematics(self) -> Kinematics:
        """The arm's nominal kinematics (its data sheet's)."""
        return self._nominal

    @property
    def absolute_accuracy(self) -> Kinematics | None:
        """The calibrated arm given to `set_absolute_accuracy`, or None (the nominal arm)."""
        return None if self._kinematics is self._nominal else self._kinematics

    def set_absolute_accuracy(self, kinematics: Kinematics | None) -> None:
        """The controller's absolute-accuracy option: move with the calibrated arm
        `kinematics` (IK, linear moves, the TCP from the encoders); None: the nominal arm, as
        a controller without the option does."""
        self._kinematics = self._nominal if kinematics is None else kinematics

    @property
    def robot(self) -> Robot:
        """The arm's model as its data sheet gives it (cell.robot_arm): the nominal kinematics,
        the parameters its calibration identifies, home, speeds; nothing of the real arm."""
        return self._robot

    def T_base_slot(self, tool: str) -> np.ndarray:
        """(4, 4) nominal pose of `tool`'s rack slot in the base frame (the cell's layout)."""
        return nominal_T_base_slot(tool, self._rack_xyz)

    @property
    def q_home(self) -> np.ndarray:
        """(6,) the arm's home configuration [rad]."""
        return self._robot.q_home.copy()

    @property
    def tools(self) -> tuple[str, ...]:
        """Names of the tools in the cell."""
        return tuple(t.name for t in TOOLS)

    def T_flange_tcp(self, tool: str | None = None) -> np.ndarray:
        """(4, 4) nominal TCP of `tool` (default: the tool in hand; the flange if none)."""
        name = tool if tool is not None else self.tool_in_hand
        if name is None:
            return np.eye(4)
        tool_index(name)  # an unknown name lists the tools
        return _TOOL_SPECS[name].T_tool_tcp

    def T_base_tcp(self) -> np.ndarray:
        """(4, 4) TCP pose computed from the encoders with the controller's kinematics."""
        return self.kinematics.fk(self.read_joints()) @ self.T_flange_tcp()

    def move_tcp(
        self, T_base_tcp: np.ndarray, speed: float = 1.0, settle_s: float = SETTLE_S
    ) -> np.ndarray:
        """Joint move to the IK solution for the TCP at `T_base_tcp`; returns the joints."""
        q = self.solve_ik(T_base_tcp)
        self.move_joints(q, speed, settle_s)
        return q

    def laser_points_base(self, reading: LaserReading) -> tuple[np.ndarray, np.ndarray]:
        """Points (M, 3) [m] of the returns in the robot base frame and their ray indices (M,),
        reconstructed with the controller's kinematics and the laser's nominal TCP from the
        measured joints."""
        return laser_points_base(
            reading, self.kinematics, self.T_flange_tcp("laser"), self.laser_directions_tcp
        )

    def _log(
        self,
        code: str,
        message: str,
        action: str,
        reading: float | None = None,
        limit: float | None = None,
    ) -> None:
        event = ControllerEvent(self.time_s, code, message, action, reading, limit)
        self.events.append(event)
        if self.on_event is not None:
            self.on_event(event)

    def _require(self, tool: str) -> None:
        if self.tool_in_hand != tool:
            raise ToolChangerError(
                f"the {tool!r} tool is not in hand (in hand: {self.tool_in_hand}); "
                f"call change_tool({tool!r}) first"
            )

    # -- state ------------------------------------------------------------------------------
    @property
    @abstractmethod
    def tool_in_hand(self) -> str | None:
        """The tool locked on the flange, or None."""

    @property
    @abstractmethod
    def time_s(self) -> float:
        """The controller's clock [s]."""

    def clock_utc(self) -> datetime:
        """The controller's date and time (aware, UTC): this computer's clock; a simulated
        cell's own where it keeps one (cell.sim.sim_controller)."""
        return datetime.now(UTC)

    @abstractmethod
    def read_joints(self) -> np.ndarray:
        """(6,) encoder readings [rad], each checked against the encoder's second channel:
        channels that disagree are read again (and logged); twice, the cell stops."""

    # -- motion -----------------------------------------------------------------------------
    @abstractmethod
    def move_joints(
        self, q_target: np.ndarray, speed: float = 1.0, settle_s: float = SETTLE_S
    ) -> None:
        """Joint move to `q_target` (6,) [rad], peak joint speeds `speed` x the limits."""

    @abstractmethod
    def solve_ik(self, T_base_tcp: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        """Joints that put the current TCP at `T_base_tcp`, seeded from the current joints."""

    @abstractmethod
    def reachable(self, T_base_tcp: np.ndarray) -> bool:
        """Whether the current TCP can reach `T_base_tcp` within the joint limits."""

    @abstractmethod
    def move_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.2,
        angular_speed_rad_s: float = 1.0,
        settle_s: float = SETTLE_S,
        T_flange_tcp: np.ndarray | None = None,
    ) -> None:
        """Straight TCP move to `T_base_tcp` at `speed_m_s` (slowed if a joint would exceed its
        speed limit), the TCP the nominal one of the tool in hand or `T_flange_tcp` (4, 4) (a
        program's tooldata). Raises UnreachableTargetError if a point of the line has no IK
        solution."""

    @abstractmethod
    def scan_linear(
        self,
        T_base_tcp: np.ndarray,
        speed_m_s: float = 0.05,
        period_s: float = 0.01,
        settle_s: float = SETTLE_S,
    ) -> list[LaserReading]:
        """Straight TCP move with the laser in hand, reading a laser line every `period_s` [s]
        while moving (each reading stamped with the encoder joints of its instant)."""

    @abstractmethod
    def sweep_beam(
        self, T_base_tcp: np.ndarray, speed_m_s: float = 0.01, settle_s: float = SETTLE_S
    ) -> list[tuple[np.ndarray, bool]]:
        """Straight TCP move through the TCP check station's beam, reading it at every
        control step: (encoder joints (6,) [rad], beam broken) at each."""

    @abstractmethod
    def read_beam(self) -> bool:
        """Whether the TCP check station's beam is broken now (its receiver's input)."""

    @property
    @abstractmethod
    def beam_line_base(self) -> tuple[np.ndarray, np.ndarray]:
        """The TCP check beam's ends (3,), (3,) [m] in the cell's layout."""

    @abstractmethod
    def servo(self, q_ref: np.ndarray, period_s: float) -> None:
        """One control period [s] of a streamed joint reference `q_ref` (6,) [rad] (an
        external guidance, as ABB's EGM streams it): the motors head for it at most at the
        joints' speed limits, under motion supervision. Raises JointLimitError for a
        reference outside the joint limits."""

    @abstractmethod
    def pace(self, clock: Callable[[float], str | None] | None) -> None:
        """Pace the cell's time: `clock(time_s)` is called every few milliseconds of the
        controller's time while the arm moves or holds (None: unpaced); a message it returns
        halts a move where it is (MotionHaltedError)."""

    @abstractmethod
    def supervision_off(self) -> AbstractContextManager[None]:
        """Motion supervision off for what is meant to push (a grasp), as a program
        switches ABB's collision detection off around a gripping move."""

    # -- tool changer -----------------------------------------------------------------------
    @abstractmethod
    def lock(self) -> str:
        """Lock the tool seated against the flange; returns its name. The lock sensor must
        say locked (one retry), and the motors' holding torques must match the tool's
        tooldata; otherwise SupervisionError."""

    @abstractmethod
    def unlock(self) -> str:
        """Release the held tool into its rack slot; returns its name."""

    def return_tool(self, T_flange_tool: np.ndarray | None = None) -> None:
        """Put the tool in hand back into its rack slot (approach from the rack's front,
        place, unlock, leave); a tool known to sit off its seat on the flange by
        `T_flange_tool` (4, 4) is placed so that it, not its seat, meets the slot."""
        name = self.tool_in_hand
        if name is None:
            return
        T_slot = self.T_base_slot(name)
        if T_flange_tool is not None:
            T_slot = T_slot @ np.linalg.inv(T_flange_tool)
        T_tcp = self.T_flange_tcp()
        self._approach(T_slot)
        self.move_linear(T_slot @ T_tcp, speed_m_s=0.1)
        self.unlock()
        # The flange is the TCP now: it leaves the seat straight up, clear of the tool.
        self.move_linear(rack_above(T_slot), speed_m_s=0.1)

    def change_tool(self, tool: str) -> None:
        """Return the tool in hand (if any), then pick `tool` from its rack slot and leave
        the rack by its front."""
        tool_index(tool)
        if self.tool_in_hand == tool:
            return
        self.return_tool()
        T_slot = self.T_base_slot(tool)
        self._approach(T_slot)
        self.move_linear(T_slot, speed_m_s=0.1)
        self.lock()
        T_tcp = self.T_flange_tcp()
        self.move_linear(rack_above(T_slot) @ T_tcp, speed_m_s=0.1)
        self.move_linear(rack_front(T_slot) @ T_tcp, speed_m_s=0.2)

    def _approach(self, T_slot: np.ndarray) -> None:
        """Joint move to the rack's front of a slot, then straight to above it (the flange
        seated pose shifted up, the tool in hand's TCP carried along)."""
        T_tcp = self.T_flange_tcp()
        q = self.kinematics.solve(rack_front(T_slot), self._q_seed())
        self.move_joints(q)
        self.move_linear(rack_above(T_slot) @ T_tcp, speed_m_s=0.2)

    def _q_seed(self) -> np.ndarray:
        """(6,) where the arm is, to seed an IK from [rad]."""
        return self.read_joints()

    # -- tools' actuators, the table, the sensors -------------------------------------------
    @abstractmethod
    def set_gripper(self, opening_m: float) -> None:
        """Command each finger to `opening_m` [m] from the centre (0 = closed), then settle."""

    @abstractmethod
    def spin_screwer(self, rad_s: float, seconds: float) -> None:
        """Run the screwer spindle at `rad_s` [rad/s] for `seconds` [s], then stop it."""

    @abstractmethod
    def move_table(
        self, position_m: float, speed_m_s: float = TABLE_SPEED, settle_s: float = SETTLE_S
    ) -> None:
        """Move the table to `position_m` [m] within its travel."""

    @abstractmethod
    def table_position(self) -> float:
        """The table axis readout [m]."""

    @abstractmethod
    def read_ir(self) -> float | None:
        """IR distance [m] along the IR tool's axis, None for no return."""

    @abstractmethod
    def read_laser(self) -> LaserReading:
        """One laser line: distances (NaN = no return) and the encoder joints at that instant."""

    @property
    def laser_latency_s(self) -> float | None:
        """The laser's latency from a line's exposure to its stamp [s] that its lines are
        paired with the encoders by; None where each line comes with the encoders of its own
        instant (nothing to identify)."""
        return None

    def set_laser_latency(self, latency_s: float) -> None:
        """Pair the laser's lines with the encoders `latency_s` [s] before their stamps;
        CellConfigError where each line comes with the encoders of its own instant."""
        raise CellConfigError(
            f"a laser latency of {latency_s!r} s: this controller pairs each laser line with "
            "the encoders of its own instant, so it has no latency to set"
        )
