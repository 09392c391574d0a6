"""Any 6-axis arm from a file (URDF or robot-only MJCF) as a `Robot`: the shared builder.

The file is read (arm_file.py) and mounted in the cell; a deviated arm's kinematics and
its robot-only MJCF (arm_mjcf.py) are made from the model with the deviations applied. Its
deviations are four per joint: the joint's zero offset [rad] and the position of its axis
in its parent link [m] (x, y, z), 24 in all.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from cell.arm_file import limit_joint_ranges, load_arm_model, motion_axis, speeds_and_efforts
from cell.arm_mjcf import Servo, arm_mjcf
from cell.kinematics import Kinematics
from cell.robot_arm import Robot


def _mount(xyz: tuple[float, float, float], yaw_deg: float) -> pin.SE3:
    c, s = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    return pin.SE3(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array(xyz, float))


def _deviated(model: pin.Model, axes: list[np.ndarray], d: np.ndarray) -> pin.Model:
    """A copy of `model` with each joint's zero offset d[4k] [rad] and axis position
    d[4k+1:4k+4] [m] (in its parent) changed."""
    out = pin.Model(model)
    for k in range(6):
        j = k + 1
        M = out.jointPlacements[j]
        offset = pin.SE3(pin.exp3(axes[k] * d[4 * k]), np.zeros(3))
        shifted = pin.SE3(M.rotation, M.translation + d[4 * k + 1 : 4 * k + 4])
        out.jointPlacements[j] = shifted * offset
    return out


#: The radius [m] of a file arm's links (capsules from each joint to the next).
FILE_ARM_RADIUS_M = 0.05


@dataclass(frozen=True, eq=False)
class JointLimits:
    """The cell's limits of a file arm's joints, each replacing the file's where given (None:
    the file's).

    Attributes:
        ranges_rad: (lower, upper) (6,) each [rad], within the file's: the cell's joint
            ranges (its safety configuration: e.g. the upper arm kept above the shoulder).
        speed_rad_s: (6,) the joints' speed limits [rad/s] (an MJCF file has none).
        effort_nm: (6,) the joints' effort limits [N m] (an MJCF file has none).
    """

    ranges_rad: tuple[np.ndarray, np.ndarray] | None = None
    speed_rad_s: np.ndarray | None = None
    effort_nm: np.ndarray | None = None


def robot_from_file(
    path: str | Path,
    tip_frame: str,
    *,
    mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0),
    mount_yaw_deg: float = 0.0,
    q_home: np.ndarray | None = None,
    servo: Servo | None = None,
    radius_m: float = FILE_ARM_RADIUS_M,
    vendor: str = "",
    name: str | None = None,
    joint_limits: JointLimits | None = None,
) -> Robot:
    """A 6-axis arm from a URDF or robot-only MJCF file, its base at `mount_xyz` [m] turned
    `mount_yaw_deg` about the vertical in the cell, the flange at frame `tip_frame`;
    `joint_limits` replace the file's joint ranges, speed and effort limits (default: the
    file's)."""
    limits = joint_limits or JointLimits()
    model = load_arm_model(path, tip_frame)
    if limits.ranges_rad is not None:
        limit_joint_ranges(model, limits.ranges_rad, path)
    model.jointPlacements[1] = _mount(mount_xyz, mount_yaw_deg) * model.jointPlacements[1]
    axes = [motion_axis(model, j) for j in range(1, 7)]
    speed, effort = speeds_and_efforts(model, limits.speed_rad_s, limits.effort_nm, path)
    home = np.zeros(6) if q_home is None else np.asarray(q_home, dtype=float)
    servo = servo or Servo(
        (2e4,) * 3 + (2e3,) * 3, (4e2,) * 3 + (4e1,) * 3, (1.0,) * 3 + (0.1,) * 3
    )
    label = name or Path(path).stem
    parameters = tuple(f"{kind}{k + 1}" for k in range(6) for kind in ("offset", "x", "y", "z"))
    lengths = np.array([kind != "offset" for _ in range(6) for kind in ("offset", "x", "y", "z")])

    def kinematics(d: np.ndarray) -> Kinematics:
        return Kinematics(_deviated(model, axes, d), tip_frame)

    def mjcf(d: np.ndarray) -> str:
        return arm_mjcf(_deviated(model, axes, d), tip_frame, servo, effort, home, radius_m, label)

    return Robot(
        label,
        vendor,
        home,
        speed,
        effort,
        parameters,
        lengths,
        kinematics,
        mjcf,
        tip_frame,
        _mount(mount_xyz, mount_yaw_deg).homogeneous,
        # Joint 1's axis position shifts the whole arm: the spheres' free centres take any
        # shift, and every tool, locked where the shifted flange meets its slot (all slots
        # face down), carries the same shift back: the calibration cannot see it and the
        # job does not need it; fitted, it only combines with joint 1's offset into a turn
        # about the spheres that the noise pulls about.
        np.array([k not in (1, 2, 3) for k in range(24)]),
        # Each joint's axis position in its parent grows with the links between them (joint
        # 1's is the arm's mount on the cell: its pedestal is not the arm's).
        np.array(
            [0.0] * 4
            + [v for j in range(2, 7) for v in (0.0, *model.jointPlacements[j].translation)]
        ),
    )
