"""Other arms for the robot-agnostic kinematics: a UR5 from example-robot-data (URDF)."""

from __future__ import annotations

import sysconfig
from pathlib import Path

from cell.errors import CellConfigError
from cell.kinematics import Kinematics


def example_robot_data_share() -> Path:
    """The `share` folder of example-robot-data (it ships data only, under cmeel.prefix)."""
    share = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share"
    if not (share / "example-robot-data").is_dir():
        raise CellConfigError(
            f"example-robot-data is not installed: {share / 'example-robot-data'} is missing; "
            "pip install example-robot-data"
        )
    return share


def ur5_kinematics() -> Kinematics:
    """Kinematics of a UR5 (ur5_robot.urdf), tip frame `tool0`."""
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    return Kinematics.from_urdf(urdf, "tool0", package_dirs=[str(share)])
