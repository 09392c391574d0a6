"""The built-in arm: the cell's IRB 2400-class arm (models.robot.arm) as a `Robot`.

Its twelve deviations are six link lengths and six joint zero offsets (see
models.robot.ArmGeometry); with a tool in hand its joint 5 is kept where the tool does not
fold into the forearm.
"""

from __future__ import annotations

import numpy as np

from cell.kinematics import Kinematics
from cell.robot_arm import Robot
from models.robot import (
    JOINT_SPEED,
    JOINT_TORQUE,
    Q_HOME,
    ROBOT_PATH,
    ArmGeometry,
    arm_xml,
)

#: Deviation names of the built-in arm, in the order of its deviation vectors (12,).
IRB_PARAMETERS: tuple[str, ...] = (
    "d1", "a1", "a2", "a3", "d4", "d6",
    "offset1", "offset2", "offset3", "offset4", "offset5", "offset6",
)  # fmt: skip

#: The built-in arm's joint 5 range in the cell with the laser in hand [rad]: beyond 100 deg
#: the laser's 12 cm body folds into the forearm (link 4); the arm's own stop is 120 deg.
IRB_LASER_WRIST_BEND_RAD = float(np.deg2rad(100.0))
#: With the screwer in hand [rad]: beyond 110 deg its changer plate comes within 5 mm of the
#: forearm (114 deg: it touches).
IRB_SCREWER_WRIST_BEND_RAD = float(np.deg2rad(110.0))


def _irb_kinematics(geometry: ArmGeometry) -> Kinematics:
    kin = Kinematics.from_geometry(geometry)
    for tool, bend in (
        ("laser", IRB_LASER_WRIST_BEND_RAD),
        ("screwer", IRB_SCREWER_WRIST_BEND_RAD),
    ):
        lower, upper = kin.lower.copy(), kin.upper.copy()
        lower[4], upper[4] = -bend, bend
        kin.tool_limits[tool] = (lower, upper)
    return kin


def irb2400() -> Robot:
    """The cell's IRB 2400-class arm (models.robot.arm), at the world's origin; with the
    laser in hand its joint 5 is kept where the laser does not fold into the forearm
    (IRB_LASER_WRIST_BEND_RAD)."""

    def geometry(d: np.ndarray) -> ArmGeometry:
        return ArmGeometry().perturbed(d[:6], d[6:])

    return Robot(
        name="irb2400",
        vendor="abb",
        q_home=np.array(Q_HOME, dtype=float),
        joint_speed=np.array(JOINT_SPEED, dtype=float),
        joint_effort=np.array(JOINT_TORQUE, dtype=float),
        parameters=IRB_PARAMETERS,
        lengths=np.array([True] * 6 + [False] * 6),
        _kinematics=lambda d: _irb_kinematics(geometry(d)),
        _mjcf=lambda d: arm_xml(geometry(d)),
        nominal_lengths=np.array([*_nominal_lengths(ArmGeometry()), *([0.0] * 6)]),
    )


def _nominal_lengths(g: ArmGeometry) -> tuple[float, ...]:
    """The six link lengths of `g` in the order of IRB_PARAMETERS [m]."""
    return (g.d1, g.a1, g.a2, g.a3, g.d4, g.d6)


def nominal_kinematics() -> Kinematics:
    """Pinocchio kinematics of the built-in arm (its robot-only MJCF), tip frame `flange`."""
    return Kinematics.from_mjcf(ROBOT_PATH, "flange")
