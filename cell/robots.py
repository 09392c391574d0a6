"""The cell's arm by the name its configuration gives: a built-in one (`BUILTIN`: the
IRB 2400-class arm, the UR5) or any 6-axis arm file (URDF or robot-only MJCF), with the
cell's mount, home and limits.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cell.cell_errors import CellConfigError
from cell.file_robot import JointLimits, robot_from_file
from cell.irb2400_arm import irb2400
from cell.robot_arm import Robot
from cell.ur5_arm import UR5_MOUNT_XYZ, ur5

#: The built-in arms by name.
BUILTIN: tuple[str, ...] = ("irb2400", "ur5")


def make_robot(
    model: str,
    flange: str | None = None,
    mount_xyz: tuple[float, float, float] | None = None,
    mount_yaw_deg: float = 0.0,
    q_home: np.ndarray | None = None,
    vendor: str | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    speed: np.ndarray | None = None,
    effort: np.ndarray | None = None,
) -> Robot:
    """The arm `model`: a built-in one by name (BUILTIN) or a 6-axis URDF / robot-only MJCF
    file with its flange frame `flange`, mounted at `mount_xyz` [m] turned `mount_yaw_deg`,
    home `q_home` (6,) [rad], joint ranges `limits` (lower, upper) (6,) [rad] (a file arm;
    default the file's). Raises CellConfigError naming what is wrong."""
    if q_home is not None:
        q_home = np.asarray(q_home, dtype=float)
        if q_home.shape != (6,) or not np.isfinite(q_home).all():
            raise CellConfigError(f"home must be 6 finite joint values, got {q_home.tolist()}")
    if model in BUILTIN and limits is not None:
        raise CellConfigError(
            f"the {model} is built in with its joint ranges; limits are for a robot file"
        )
    if model == "irb2400":
        if flange is not None or mount_xyz is not None or mount_yaw_deg:
            raise CellConfigError(
                "the irb2400 is built in: it has its flange and stands at the cell's origin "
                "(flange and mount are for a robot file or the ur5)"
            )
        robot = irb2400()
        if q_home is not None:
            robot = replace(robot, q_home=q_home)
    elif model == "ur5":
        if flange is not None:
            raise CellConfigError("the ur5 is built in: its flange is tool0")
        robot = ur5(
            UR5_MOUNT_XYZ if mount_xyz is None else mount_xyz,
            mount_yaw_deg,
            q_home,
        )
    else:
        if not flange:
            raise CellConfigError(
                f"robot file {model}: name its flange frame (built-in arms: {', '.join(BUILTIN)})"
            )
        robot = robot_from_file(
            model,
            flange,
            mount_xyz=(0.0, 0.0, 0.0) if mount_xyz is None else mount_xyz,
            mount_yaw_deg=mount_yaw_deg,
            q_home=q_home,
            joint_limits=JointLimits(limits, speed, effort),
        )
    if q_home is not None:
        kin = robot.kinematics()
        if (q_home < kin.lower).any() or (q_home > kin.upper).any():
            raise CellConfigError(
                f"{robot.name}: home {np.round(q_home, 4).tolist()} rad is outside the joint "
                f"limits {np.round(kin.lower, 4).tolist()} .. {np.round(kin.upper, 4).tolist()}"
            )
    return robot if vendor is None else replace(robot, vendor=vendor)
