"""Writing the robot-only MJCF of a 6-axis Pinocchio arm, named as the cell expects.

Bodies `base`, `link1`..`link6`, joints and position servos `joint1`..`joint6` (their gains:
`Servo`), a `flange` site at the tip frame; each link a capsule (no meshes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from cell.arm_file import motion_axis
from models.robot import JOINT_NAMES
from models.robot.arm import LinkXml, arm_document, servo_actuators


@dataclass(frozen=True)
class Servo:
    """Position servos of a file arm: stiffness [N m/rad], damping [N m s/rad] and the
    rotor inertia reflected through each gearbox [kg m^2], per joint (6,)."""

    kp: tuple[float, ...]
    kv: tuple[float, ...]
    armature: tuple[float, ...]


def _f(values: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(f"{float(v):.12g}" for v in values)


def _six(inertia: np.ndarray) -> tuple[float, ...]:
    """MJCF's fullinertia order: Ixx, Iyy, Izz, Ixy, Ixz, Iyz."""
    i = np.asarray(inertia)
    return (i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])


def _quat(R: np.ndarray) -> str:
    q = pin.Quaternion(R)
    return _f((q.w, q.x, q.y, q.z))


def arm_mjcf(
    model: pin.Model,
    tip_frame: str,
    servo: Servo,
    effort: np.ndarray,
    q_home: np.ndarray,
    radius_m: float,
    name: str,
) -> str:
    """The robot-only MJCF of a 6-axis Pinocchio model, named as the cell expects: bodies
    `base`, `link1`..`link6`, joints and servos `joint1`..`joint6`, a `flange` site at the
    tip frame. Each link's geometry is a capsule of `radius_m` from its joint to the next
    (kinematics and inertias are the model's; no meshes); a pedestal stands under the
    mount."""
    tip = model.frames[model.getFrameId(tip_frame)]
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    mount = model.jointPlacements[1].translation

    def link(k: int) -> LinkXml:
        j = k + 1
        M = model.jointPlacements[j]
        inertia = model.inertias[j]
        inertia_com = inertia.inertia  # about the centre of mass, joint frame
        inertial = (
            f'<inertial pos="{_f(inertia.lever)}" mass="{inertia.mass:.12g}" '
            f'fullinertia="{_f(_six(inertia_com))}"/>'
            if inertia.mass > 0
            else '<inertial pos="0 0 0" mass="1e-6" diaginertia="1e-9 1e-9 1e-9"/>'
        )
        child = model.jointPlacements[j + 1].translation if j < 6 else tip.placement.translation
        geoms: tuple[str, ...] = ()
        if np.linalg.norm(child) > 1e-3:
            geoms = tuple(
                f'<geom class="{cls}" type="capsule" size="{radius_m:g}" '
                f'fromto="0 0 0 {_f(child)}"/>'
                for cls in ("collision", "visual")
            )
        return LinkXml(
            f"link{j}",
            f' pos="{_f(M.translation)}" quat="{_quat(M.rotation)}"',
            inertial,
            f'<joint name="{JOINT_NAMES[k]}" axis="{_f(motion_axis(model, j))}" '
            f'range="{lower[k]:.12g} {upper[k]:.12g}" armature="{servo.armature[k]:g}"/>',
            geoms,
        )

    height = max(float(mount[2]), 0.01)
    pedestal = (
        f'type="cylinder" size="0.1 {height / 2:.6g}"\n'
        f'            pos="{mount[0]:.6g} {mount[1]:.6g} {height / 2:.6g}"/>'
    )
    P = tip.placement
    return arm_document(
        name,
        [link(k) for k in range(6)],
        (
            '<inertial pos="0 0 0.1" mass="50" diaginertia="1 1 1"/>',
            f'<geom class="collision" {pedestal}',
            f'<geom class="visual" {pedestal}',
        ),
        f'<site name="flange" pos="{_f(P.translation)}" quat="{_quat(P.rotation)}" size="0.01"/>',
        servo_actuators(lower, upper, effort, servo.kp, servo.kv),
        q_home,
        "0.35 0.55 0.75 1",
        # The first link turns on the base bolted to the floor: its capsule's end (a radius
        # below the joint-1 origin) stands for the base casting, not for a link that could
        # meet the floor; an arm mounted at floor level would otherwise touch it everywhere.
        on_floor=("link1",),
    )
