"""The simulated truth of a real cell. Only evaluators (and tests) read it; planning never does."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
import pinocchio as pin

from cell.cell_errors import CellConfigError, UnknownNameError
from cell.kinematics import Kinematics, payload_model
from cell.sim.config import CellConfig
from cell.sim.devices import TableAxis
from cell.sim.faults import FaultInjector
from cell.sim.real import RealParameters, fault_fixtures
from cell.sim.sensors import IRSensor, LaserScanner
from cell.sim.simulation import Simulation
from cell.sim.toolchanger import flange_offset
from models.robot import TOOLS


class CellTruth:
    """The real cell's hidden parameters and live true state."""

    def __init__(
        self,
        config: CellConfig,
        params: RealParameters,
        sim: Simulation,
        table: TableAxis,
        laser: LaserScanner | None = None,
        ir: IRSensor | None = None,
        faults: FaultInjector | None = None,
        motors: Callable[[], np.ndarray] | None = None,
    ) -> None:
        self.config = config
        self._motors = motors
        self.params = params
        self._sim = sim
        self._table = table
        self._laser = laser
        self._ir = ir
        self.faults = faults or FaultInjector((), config.seed)
        self._gravity: dict[str | None, tuple[pin.Model, pin.Data]] = {}
        self._kinematics: Kinematics | None = None

    @property
    def deviations(self) -> np.ndarray:
        """The real arm's kinematic deviations from its nominal (see cell.robot_arm)."""
        return self.params.deviations

    def watch(
        self,
        bodies: Callable[[mujoco.MjData], None] | None,
        laser: Callable[[mujoco.MjData, np.ndarray, np.ndarray, np.ndarray], None] | None,
        period_s: float = 1.0 / 30.0,
        ir: Callable[[mujoco.MjData, np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    ) -> None:
        """Witness the real cell: `bodies(data)` every `period_s` [s] of simulated time, and
        `laser(data, origin, directions, ranges)` at every laser line (world frame, ranges as
        measured), `ir` alike at every IR reading. For the recording of a run; None stops
        any of them."""
        self._sim.watch(bodies, period_s)
        if self._laser is not None:
            self._laser.witness = laser
        if self._ir is not None:
            self._ir.witness = ir

    @property
    def simulation(self) -> Simulation:
        """The physics (MuJoCo model and data) of the real cell."""
        return self._sim

    def q(self) -> np.ndarray:
        """(6,) true joint positions [rad]."""
        return self._sim.arm_q()

    def motor_angles(self) -> np.ndarray:
        """(6,) the motors' true angles [rad]: the links' plus the drives' offsets (what the
        encoders measure before their noise)."""
        if self._motors is None:
            raise CellConfigError("this cell's truth was built without its drives")
        return self._motors()

    def table_position_m(self) -> float:
        """True table slide position [m] (readout plus the axis' positioning error)."""
        return self._sim.table_q()

    def table_error_m(self) -> float:
        """Current positioning error of the table axis [m]."""
        return self._table.error_m

    def T_base_table(self) -> np.ndarray:
        """(4, 4) true pose of the table frame in the robot base frame."""
        return self._sim.site_T(self._sim.model.site("table_top").id)

    def T_base_object(self, name: str) -> np.ndarray:
        """(4, 4) true pose, NOW, of an object on the table in the robot base frame: a fixed
        one rides on the table; a loose one (a free body) is wherever physics has put it."""
        for obj in (*self.config.fixtures, *fault_fixtures(self.config)):
            if obj.name == name:
                moved = self.faults.T_table_moved.get(name, np.eye(4))
                return self.T_base_table() @ moved @ obj.T_table_object
        for part in self.config.parts:
            if part.name == name:
                return self._sim.body_T(self._sim.model.body(name).id)
        names = ", ".join(o.name for o in (*self.config.fixtures, *self.config.parts)) or "none"
        raise UnknownNameError(f"no object {name!r} on the table; objects: {names}")

    def T_base_tcp(self, tool: str) -> np.ndarray:
        """(4, 4) true pose of `tool`'s TCP site (wherever the tool is)."""
        return self._sim.site_T(self._sim.tcp_site[tool])

    def link_angles(self, q_motor: np.ndarray, tool: str | None) -> np.ndarray:
        """(6,) where the real links are for motor angles `q_motor` (6,) [rad] at rest with
        `tool` in hand: the joints' sag under gravity (the drives' lost motion and
        repeatability, which depend on the motion, aside)."""
        q = np.asarray(q_motor, dtype=float)
        k = self.params.stiffness_nm_rad
        if not np.any(k > 0.0):
            return q.copy()
        if tool not in self._gravity:
            model = payload_model(self.kinematics(), tool)
            self._gravity[tool] = (model, model.createData())
        model, data = self._gravity[tool]
        c6 = np.zeros(6)
        c6[1:3] = np.where(k > 0.0, 1.0 / np.where(k > 0.0, k, 1.0), 0.0)
        return q - c6 * np.asarray(pin.computeGeneralizedGravity(model, data, q))

    def T_tool_tcp(self, tool: str) -> np.ndarray:
        """(4, 4) `tool`'s true TCP in its frame (the laser's: its optical frame)."""
        if tool in self.params.T_tool_tcp:
            return self.params.T_tool_tcp[tool].copy()
        return {t.name: t for t in TOOLS}[tool].T_tool_tcp

    def kinematics(self) -> Kinematics:
        """Pinocchio kinematics of the REAL arm (the robot with the drawn deviations)."""
        if self._kinematics is None:
            self._kinematics = self.config.robot.kinematics(self.params.deviations)
        return self._kinematics

    def T_flange_tool(self, tool: str) -> np.ndarray:
        """(4, 4) true pose of `tool`'s frame in the true flange frame."""
        return flange_offset(self._sim, tool)
