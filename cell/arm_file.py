"""Reading a 6-axis arm file (URDF or robot-only MJCF) as the cell needs it.

The Pinocchio model of the file, checked (six revolute joints, a flange frame along the last
joint's axis; a gripper's joints locked), its joints' axes, and its joint ranges, speed and
effort limits (the cell's where it gives them, else the file's, else defaults).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from cell.cell_errors import CellConfigError


def load_arm_model(path: str | Path, tip_frame: str) -> pin.Model:
    """The Pinocchio model of a 6-axis arm file (URDF or robot-only MJCF), joints that do not
    move the flange (a gripper's) locked at their neutral value; raises
    CellConfigError for a missing file, another format, a missing tip frame, or other than
    six revolute joints."""
    p = Path(path)
    if not p.is_file():
        raise CellConfigError(f"robot file not found: {p}")
    suffix = p.suffix.lower()
    try:
        if suffix == ".urdf":
            model = pin.buildModelFromUrdf(str(p))
        elif suffix in (".xml", ".mjcf"):
            model = pin.buildModelFromMJCF(str(p))
        else:
            raise CellConfigError(
                f"robot file {p} has unknown format {p.suffix!r}; valid: .urdf, .xml (MJCF)"
            )
    except (RuntimeError, ValueError) as exc:
        raise CellConfigError(f"{p}: cannot be read as a robot: {exc}") from None
    if model.existFrame(tip_frame) and model.nq != 6:
        model = _chain_to(model, tip_frame)
    revolute = [
        model.names[j]
        for j in range(1, model.njoints)
        if model.joints[j].shortname().startswith(("JointModelR", "JointModelRevolute"))
    ]
    if model.nq != 6 or len(revolute) != 6:
        raise CellConfigError(
            f"{p}: the cell needs a 6-axis arm (six revolute joints); this one has {model.nq} "
            f"position variables and revolute joints {revolute}"
        )
    frames = [
        f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)
    ]
    if not model.existFrame(tip_frame):
        raise CellConfigError(
            f"{p}: no frame {tip_frame!r} for the flange; its frames are {frames}"
        )
    cosine = _flange_axis_cosine(model, tip_frame)
    if abs(cosine) < np.cos(np.deg2rad(5.0)):
        raise CellConfigError(
            f"{p}: the flange frame {tip_frame!r} has its z axis "
            f"{np.rad2deg(np.arccos(np.clip(abs(cosine), 0.0, 1.0))):.0f} deg off the last "
            "joint's axis; the tools mount along the flange's z axis, so name a frame whose z "
            f"axis points out of the wrist (cell.robot.flange; its frames are {frames})"
        )
    return model


def _flange_axis_cosine(model: pin.Model, tip_frame: str) -> float:
    """Cosine between the flange frame's z axis and the last joint's axis."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    last = model.njoints - 1
    axis = data.oMi[last].rotation @ motion_axis(model, last)
    return float(data.oMf[model.getFrameId(tip_frame)].rotation[:, 2] @ axis)


def _chain_to(model: pin.Model, tip_frame: str) -> pin.Model:
    """`model` with the joints that do not move `tip_frame` (a gripper's fingers, say)
    locked at their neutral value: the arm that carries the flange."""
    parent = model.frames[model.getFrameId(tip_frame)].parentJoint
    chain = set(model.supports[parent])
    locked = [j for j in range(1, model.njoints) if j not in chain]
    if not locked:
        return model
    return pin.buildReducedModel(model, locked, pin.neutral(model))


def motion_axis(model: pin.Model, j: int) -> np.ndarray:
    """Unit axis (3,) of revolute joint j in its own frame (its constant motion subspace)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    S = np.asarray(data.joints[j].S).reshape(6)
    return S[3:] / np.linalg.norm(S[3:])


def limit_joint_ranges(
    model: pin.Model, limits: tuple[np.ndarray, np.ndarray], path: str | Path
) -> None:
    """Narrow `model`'s joint ranges to `limits` (lower, upper) (6,) [rad], which must lie
    within the file's."""
    lower, upper = (np.asarray(v, dtype=float) for v in limits)
    if (
        lower.shape != (6,)
        or upper.shape != (6,)
        or (lower >= upper).any()
        or (lower < model.lowerPositionLimit - 1e-9).any()
        or (upper > model.upperPositionLimit + 1e-9).any()
    ):
        raise CellConfigError(
            f"{path}: joint ranges {lower.tolist()} .. {upper.tolist()} rad must be six "
            f"increasing pairs within the arm's {model.lowerPositionLimit.tolist()} .. "
            f"{model.upperPositionLimit.tolist()}"
        )
    model.lowerPositionLimit, model.upperPositionLimit = lower, upper


def _mjcf_efforts(path: str | Path, model: pin.Model) -> np.ndarray:
    """The arm's joints' effort limits [N m] (6,) as its MJCF file states them (inf where
    it does not): a joint's actuator force range, else the largest force range of the
    actuators driving it (MuJoCo's own parser, its default classes applied; the meshes are
    not read)."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(path))
    joints = {j.name: j for j in spec.joints}
    out = np.full(6, np.inf)
    for k in range(6):
        name = model.names[k + 1]
        joint = joints.get(name)
        if joint is not None and joint.actfrclimited == mujoco.mjtLimited.mjLIMITED_TRUE:
            out[k] = float(np.max(np.abs(joint.actfrcrange)))
            continue
        ranges = [
            float(np.max(np.abs(a.forcerange)))
            for a in spec.actuators
            if a.target == name
            and a.forcelimited != mujoco.mjtLimited.mjLIMITED_FALSE
            and np.any(a.forcerange)
        ]
        if ranges:
            out[k] = max(ranges)
    return out


#: The joints' speed limits [rad/s] a file arm gets where its file has none (an MJCF file):
#: 90 deg/s for the main axes and 180 deg/s for the wrist, below the data sheets of 6-axis
#: arms of 0.5-1.3 m reach (a cautious choice: cell.robot.speed_deg_s gives the real ones).
DEFAULT_SPEED_RAD_S = np.deg2rad([90.0, 90.0, 90.0, 180.0, 180.0, 180.0])


def speeds_and_efforts(
    model: pin.Model, speed: np.ndarray | None, effort: np.ndarray | None, path: str | Path
) -> tuple[np.ndarray, np.ndarray]:
    """The joints' speed [rad/s] and effort [N m] limits (6,) each: those given, else the
    file's (a speed the file does not give: DEFAULT_SPEED_RAD_S; an MJCF file's efforts from
    its joints' and actuators' force ranges); every one finite and positive."""
    if speed is None:
        file_speed = np.asarray(model.velocityLimit, dtype=float)
        given = np.isfinite(file_speed) & (file_speed > 0)
        speed = np.where(given, file_speed, DEFAULT_SPEED_RAD_S)
    speed = np.asarray(speed, dtype=float)
    if effort is None:
        effort = np.asarray(model.effortLimit, dtype=float)
        if Path(path).suffix.lower() != ".urdf" and not np.isfinite(effort).all():
            effort = np.where(np.isfinite(effort), effort, _mjcf_efforts(path, model))
    effort = np.asarray(effort, dtype=float)
    if (
        speed.shape != (6,)
        or effort.shape != (6,)
        or not (np.isfinite(speed).all() and np.isfinite(effort).all())
        or (speed <= 0).any()
        or (effort <= 0).any()
    ):
        raise CellConfigError(
            f"{path}: every joint needs a finite positive speed and effort limit (got "
            f"{speed.tolist()} rad/s, {effort.tolist()} N m); give them in the cell "
            "(cell.robot.speed_deg_s, cell.robot.effort_nm) where the file has none or they "
            "are wrong"
        )
    return speed, effort
