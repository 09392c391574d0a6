"""The UR5 of example-robot-data as the cell's arm: its file, its mount, home and joint
ranges in the cell, and its servos.
"""

from __future__ import annotations

import sysconfig
from pathlib import Path

import numpy as np

from cell.arm_mjcf import Servo
from cell.cell_errors import CellConfigError
from cell.file_robot import JointLimits, robot_from_file
from cell.kinematics import Kinematics
from cell.robot_arm import Robot


def example_robot_data_share() -> Path:
    """The `share` folder of example-robot-data (it ships data only, under cmeel.prefix)."""
    share = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share"
    if not (share / "example-robot-data").is_dir():
        raise CellConfigError(
            f"example-robot-data is not installed: {share / 'example-robot-data'} is missing; "
            "pip install example-robot-data"
        )
    return share


def ur5_urdf() -> Path:
    """The UR5's URDF in example-robot-data."""
    return (
        example_robot_data_share()
        / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    )  # fmt: skip


#: Where the UR5 stands in the cell: on a pedestal at the table's near corner (clear of the
#: table's sweep), the table and the rack (cell ur5) within its 0.85 m reach.
UR5_MOUNT_XYZ = (0.55, -0.1, 0.45)
UR5_MOUNT_YAW_DEG = 0.0
UR5_HOME = np.array([0.0, -1.2, 1.6, -1.97, -1.5708, 0.0])
#: The UR5's joint ranges in the cell [rad], its safety configuration: the upper arm above
#: the shoulder and the elbow bent up (no pose reaches down through the pedestal or the
#: table), one wrist configuration (wrist 2 negative), and wrist 1 kept where no tool on the
#: flange folds back into the forearm or the upper arm (over those ranges the tools' bodies
#: stay clear of both by the arm's and the tools' radii).
UR5_LIMITS = (
    np.array([-np.pi, -np.pi, 0.0, -4.5, -2.6, -2 * np.pi]),
    np.array([np.pi, 0.0, np.pi, -0.2, -0.05, 2 * np.pi]),
)


def ur5(
    mount_xyz: tuple[float, float, float] = UR5_MOUNT_XYZ,
    mount_yaw_deg: float = UR5_MOUNT_YAW_DEG,
    q_home: np.ndarray | None = None,
) -> Robot:
    """The UR5 of example-robot-data (URDF, flange `tool0`) mounted for the cell, its servos
    sized for its 3 kg payload class."""
    return robot_from_file(
        ur5_urdf(),
        "tool0",
        mount_xyz=mount_xyz,
        mount_yaw_deg=mount_yaw_deg,
        q_home=UR5_HOME if q_home is None else q_home,
        servo=Servo(
            kp=(1e4, 1e4, 6e3, 1e3, 1e3, 5e2),
            kv=(2e2, 2e2, 1.2e2, 2e1, 2e1, 1e1),
            armature=(0.5, 0.5, 0.3, 0.05, 0.05, 0.03),
        ),
        radius_m=0.045,
        vendor="universal robots",
        name="ur5",
        joint_limits=JointLimits(ranges_rad=UR5_LIMITS),
    )


def ur5_kinematics() -> Kinematics:
    """Kinematics of the UR5 (ur5_robot.urdf) at the origin, tip frame `tool0`."""
    share = example_robot_data_share()
    return Kinematics.from_urdf(ur5_urdf(), "tool0", package_dirs=[str(share)])
