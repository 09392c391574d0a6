"""What the cell believes of itself: the model its in-cell calibration identifies, which the
scan, the program and the export then use in place of the data sheet's.

- The arm: its kinematics with the identified deviations, and the compliance of joints 2
  and 3 under gravity (`CompliantKinematics`: the motors' angles in, as the controller
  commands and the encoders read them; the links sag by the gravity torque of the arm and
  its payload, from the data sheet's inertias and the tool's nominal mass, times the
  identified compliance).
- The laser: its optical frame on its tool plate and its range scale.
- The table axis: its pose along its travel (`TableModel`), the nominal straight travel
  corrected by a smooth deviation identified from the spheres seen at several positions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pinocchio as pin

from cell import Kinematics, nominal_T_base_table
from cell.kinematics import IKResult, payload_model
from models.robot import LASER, TABLE_TRAVEL
from registration.rigid import rotvecs_to_R

#: The table model's terms per component: linear and quadratic in u = s / half the travel.
TABLE_COMPONENTS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")


class CompliantKinematics(Kinematics):
    """The arm with joints 2 and 3 compliant under gravity: joint angles are the motors'
    (see the module's docstring); `links` the rigid kinematics of the links, `compliance`
    (2,) [rad/(N m)] of joints 2 and 3, `tool` the payload (None: the bare flange)."""

    def __init__(self, links: Kinematics, compliance: np.ndarray, tool: str | None = None) -> None:
        super().__init__(links.model, links.tip_frame)
        self.links = links
        self.tool_limits = dict(links.tool_limits)
        limited = links.for_tool(tool)
        self.lower, self.upper = limited.lower.copy(), limited.upper.copy()
        self.compliance = np.zeros(6)
        self.compliance[1:3] = np.asarray(compliance, dtype=float)
        self.tool = tool
        self._gravity_model = payload_model(links, tool)
        self._gravity_data = self._gravity_model.createData()
        self._for: dict[str | None, CompliantKinematics] = {tool: self}

    def for_tool(self, tool: str | None) -> CompliantKinematics:
        """The same arm carrying `tool`."""
        if tool not in self._for:
            other = CompliantKinematics(self.links, self.compliance[1:3], tool)
            other._for = self._for
            self._for[tool] = other
        return self._for[tool]

    def sag(self, q: np.ndarray) -> np.ndarray:
        """(6,) motor minus link angle [rad] at joints `q`."""
        g = pin.computeGeneralizedGravity(
            self._gravity_model, self._gravity_data, np.asarray(q, dtype=float)
        )
        return self.compliance * np.asarray(g)

    def link_angles(self, q_motor: np.ndarray) -> np.ndarray:
        """(6,) where the links are for motor angles `q_motor` (6,) [rad]."""
        q = np.asarray(q_motor, dtype=float)
        return q - self.sag(q)

    def motor_angles(self, q_link: np.ndarray) -> np.ndarray:
        """(6,) the motor angles that put the links at `q_link` (6,) [rad]."""
        q_link = np.asarray(q_link, dtype=float)
        q = q_link + self.sag(q_link)
        return q_link + self.sag(q)  # one fixed-point step: the sag at the motors' angles

    def fk(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        return super().fk(self.link_angles(q), frame)

    def jacobian(self, q: np.ndarray, frame: str | None = None, local: bool = False) -> np.ndarray:
        return super().jacobian(self.link_angles(q), frame, local)

    def ik(
        self, T_base_target: np.ndarray, q_seed: np.ndarray, *args: Any, **kwargs: Any
    ) -> IKResult:
        result = super().ik(T_base_target, self.link_angles(q_seed), *args, **kwargs)
        return replace(result, q=np.clip(self.motor_angles(result.q), self.lower, self.upper))


@dataclass(frozen=True, eq=False)
class TableModel:
    """The table axis' pose along its travel: T_base_table(s) = nominal(s) @ D(s), D's
    translation [m] and rotation vector [rad] (components x, y, z, rx, ry, rz) each
    c1 u + c2 (u^2 - 1/3) with u = s / half the travel (`coefficients` (6, 2); zero: the
    nominal straight travel). A constant term would be the table's pose at the middle of its
    travel, which the objects' own poses take up."""

    coefficients: np.ndarray

    @classmethod
    def nominal(cls) -> TableModel:
        return cls(np.zeros((6, 2)))

    def deviation(self, s: float) -> np.ndarray:
        """(4, 4) D(s): the carriage's deviation from the nominal at table position `s` [m]."""
        return self.deviations(np.array([s]))[0]

    def deviations(self, s: np.ndarray) -> np.ndarray:
        """(L, 4, 4) D(s) at each table position of `s` (L,) [m], at once."""
        s = np.asarray(s, dtype=float).reshape(-1)
        lo, hi = TABLE_TRAVEL
        u = (s - (lo + hi) / 2.0) / ((hi - lo) / 2.0)
        d = np.stack([u, u * u - 1.0 / 3.0], axis=1) @ self.coefficients.T  # (L, 6)
        out = np.broadcast_to(np.eye(4), (len(s), 4, 4)).copy()
        out[:, :3, :3] = rotvecs_to_R(d[:, 3:])
        out[:, :3, 3] = d[:, :3]
        return out

    def T_base_table(self, s: float) -> np.ndarray:
        """(4, 4) the table frame in the base frame at table position `s` [m]."""
        return nominal_T_base_table(s) @ self.deviation(s)

    def T_base_tables(self, s: np.ndarray) -> np.ndarray:
        """(L, 4, 4) `T_base_table` at each table position of `s` (L,) [m], at once."""
        s = np.asarray(s, dtype=float).reshape(-1)
        return np.array([nominal_T_base_table(x) for x in s]) @ self.deviations(s)


@dataclass(frozen=True, eq=False)
class CellModel:
    """The cell as the program believes it (see the module's docstring).

    Attributes:
        kinematics: the arm (a `CompliantKinematics` after a calibration; motor angles in).
        T_tool_laser: (4, 4) the laser's optical frame (where its rays start) in its tool
            frame; laser_scale: its range scale error (a measured range is (1 + scale) times
            the true one).
        table: the table axis' pose along its travel.
    """

    kinematics: Kinematics
    T_tool_laser: np.ndarray
    laser_scale: float
    table: TableModel

    @classmethod
    def nominal(cls, kinematics: Kinematics) -> CellModel:
        """The data sheet's cell: the nominal arm, the laser as designed, a straight table."""
        return cls(kinematics, LASER.T_tool_tcp, 0.0, TableModel.nominal())

    def T_base_table(self, s: float) -> np.ndarray:
        """(4, 4) the table frame at table position `s` [m] (the axis' readout)."""
        return self.table.T_base_table(s)

    def laser_points(self, distances: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N, 3) points in the laser's tool frame of ranges `distances` (N,) [m] measured
        along `directions` (N, 3) (unit, optical frame)."""
        p = directions * (np.asarray(distances)[:, None] / (1.0 + self.laser_scale))
        return p @ self.T_tool_laser[:3, :3].T + self.T_tool_laser[:3, 3]
