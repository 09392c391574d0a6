"""What a run hands the rest of the user's toolchain besides the RAPID module: the arm as URDF
(nominal, and calibrated when the job calibrated it), the tool's data, and the corrected
targets as CSV and JSON for any controller."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pinocchio as pin

from cell import Kinematics
from cell.robot_arm import Robot
from models.atomic import write_text
from models.robot import TOOLS
from models.robot.urdf import urdf_text
from registration.rigid import R_to_quat_wxyz
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.rapid_text import tooldata_text


def _with_limits(kinematics: Kinematics, robot: Robot) -> pin.Model:
    """A copy of the arm's model in its own base frame (the mount taken out of the first
    joint's placement) with the robot's speed and effort limits (its data sheet's, which the
    model built from the built-in arm's MJCF does not carry)."""
    model = pin.Model(kinematics.model)
    T = robot.T_world_base
    model.jointPlacements[1] = pin.SE3(T[:3, :3], T[:3, 3]).inverse() * model.jointPlacements[1]
    model.upperVelocityLimit = np.asarray(robot.joint_speed, dtype=float)
    model.upperEffortLimit = np.asarray(robot.joint_effort, dtype=float)
    return model


def write_robot_urdf(
    folder: Path, robot: Robot, nominal: Kinematics, calibrated: Kinematics | None
) -> list[Path]:
    """robot_nominal.urdf and, if the arm was calibrated, robot_calibrated.urdf (the
    identified kinematic parameters), in the arm's own base frame (as targets.csv), tip link
    the flange frame (ABB's and UR's tool0)."""
    written = [
        write_text(
            folder / "robot_nominal.urdf",
            urdf_text(_with_limits(nominal, robot), "arm_nominal", nominal.tip_frame),
        )
    ]
    if calibrated is not None:
        written.append(
            write_text(
                folder / "robot_calibrated.urdf",
                urdf_text(_with_limits(calibrated, robot), "arm_calibrated", calibrated.tip_frame),
            )
        )
    return written


def write_tooldata(folder: Path, tool: str) -> Path:
    """tooldata.json: the tool's TCP in the flange frame (4, 4) [m], position [m] and
    scalar-first quaternion, mass [kg], and its RAPID tooldata declaration."""
    spec = {t.name: t for t in TOOLS}[tool]
    T = spec.T_tool_tcp
    data = {
        "tool": tool,
        "T_flange_tcp": T.tolist(),
        "position_m": T[:3, 3].tolist(),
        "quaternion_wxyz": R_to_quat_wxyz(T[:3, :3]).tolist(),
        "mass_kg": spec.mass,
        "rapid": tooldata_text(tool),
    }
    return write_text(folder / "tooldata.json", json.dumps(data, indent=2) + "\n")


def write_targets(
    folder: Path,
    program: OfflineProgram,
    T_world_base: np.ndarray | None = None,
    kinematics: Kinematics | None = None,
) -> list[Path]:
    """targets.csv and targets.json: every corrected target of the program in the arm's own
    base frame (approach and touch poses of the TCP, position [m] and scalar-first
    quaternion, joints [rad]) at the program's table position [m]: what any controller needs
    to run it. `T_world_base` (4, 4) is where the arm's base stands in the cell (its mount;
    default: at the cell's origin). The joints q*_rad are the ones to command (the motors'
    angles); q*_link_rad are where the links then are, with the calibrated `kinematics`'
    joint sag (the angles at which robot_calibrated.urdf has the TCP on the target)."""
    T_base_world = np.linalg.inv(np.eye(4) if T_world_base is None else T_world_base)
    arm = None if kinematics is None else kinematics.for_tool(program.tool)

    def links(q: np.ndarray) -> np.ndarray:
        link_angles = getattr(arm, "link_angles", None)
        return np.asarray(q) if link_angles is None else link_angles(q)

    rows = []
    for planned in program.operations:
        for kind, T, q in (
            ("approach", T_base_world @ planned.T_base_approach, planned.q_approach),
            ("touch", T_base_world @ planned.T_base_touch, planned.q_touch),
        ):
            w, x, y, z = (float(v) for v in R_to_quat_wxyz(T[:3, :3]))
            rows.append(
                {"operation": planned.operation.name, "pose": kind}
                | {"table_position_m": program.table_position_m}
                | {"x_m": float(T[0, 3]), "y_m": float(T[1, 3]), "z_m": float(T[2, 3])}
                | {"qw": w, "qx": x, "qy": y, "qz": z}
                | {f"q{k + 1}_rad": float(v) for k, v in enumerate(q)}
                | {f"q{k + 1}_link_rad": float(v) for k, v in enumerate(links(q))}
            )
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]) if rows else ["operation"])
    writer.writeheader()
    writer.writerows(rows)
    data = {
        "tool": program.tool,
        "table_position_m": program.table_position_m,
        "T_table_object": program.T_table_object.tolist(),
        "frame": "the arm's base; poses of the tool's TCP",
        "T_cell_base": (np.eye(4) if T_world_base is None else T_world_base).tolist(),
        "targets": rows,
    }
    return [
        write_text(folder / "targets.csv", buffer.getvalue()),
        write_text(folder / "targets.json", json.dumps(data, indent=2) + "\n"),
    ]
