"""A fixed-base arm held by a Pinocchio model, written as a URDF for other tools (e.g. ROS).

Kinematics and inertias only: the URDF has no meshes, no <visual> and no <collision> elements.

Frames: URDF gives every link the frame of the joint that moves it, so the link of Pinocchio's
joint j is joint j's frame, placed in its parent link by `model.jointPlacements[j]`; the root
link (`base_link`) is the model's base frame (the universe). Inertias are expressed in the link
frame, as Pinocchio's are in the joint frame. A fixed joint carries a link named after the tip
frame (the flange, ABB's tool0) at that frame's placement. Units: m, rad, kg, kg m^2, N m or N,
rad/s or m/s. Numbers are written in Python's shortest round-trip form (`repr`), so reading the
file back gives the same floats; angles are URDF roll-pitch-yaw about fixed axes,
R = Rz(yaw) Ry(pitch) Rx(roll).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from models.atomic import write_text

#: Stand-in for a massless moving body [kg, kg m^2 about its joint origin]: MuJoCo (and other
#: simulators) refuse a moving body without mass and inertia; 1e-10 is far below any link's.
MASSLESS_MASS = 1e-10
MASSLESS_MOMENT = 1e-13

#: URDF joint type of each Pinocchio joint the exporter handles (by `JointModel.shortname()`).
JOINT_TYPES: dict[str, str] = {
    "JointModelRX": "revolute",
    "JointModelRY": "revolute",
    "JointModelRZ": "revolute",
    "JointModelRevoluteUnaligned": "revolute",
    "JointModelPX": "prismatic",
    "JointModelPY": "prismatic",
    "JointModelPZ": "prismatic",
    "JointModelPrismaticUnaligned": "prismatic",
}


def urdf_text(model: pin.Model, name: str, tip_frame: str, base_link: str = "base_link") -> str:
    """The URDF (robot `name`) of the fixed-base arm held by `model`, up to `tip_frame`.

    Links: `base_link` is the base frame (the universe); the link of joint j is named after
    the model's body frame at joint j's frame (placement identity) if there is one, else
    `<joint>_link`. Each link carries its body's inertia (`model.inertias`: mass [kg], centre
    of mass [m] in the link frame, inertia tensor about the centre of mass in link axes
    [kg m^2]). A massless body (zero spatial inertia) that a joint moves gets a tiny valid
    inertia instead (`MASSLESS_MASS` at the joint origin, principal moments `MASSLESS_MOMENT`);
    massless fixed links (`base_link`, the tip) get no <inertial>, which URDF reads as zero.
    The base's own inertia, if any, goes on a link `<base_link>_inertia` fixed to `base_link`:
    KDL (ROS's kdl_parser) does not support a root link with an inertia.

    Joints: revolute and prismatic joints (`JOINT_TYPES`) with their placement in the parent
    link, their axis (the joint's motion subspace) and <limit>: the position limits [rad or
    m] and the upper effort [N m or N] and velocity [rad/s or m/s] limits (URDF's are
    symmetric). The tip frame becomes a link fixed to its parent joint's link at the frame's
    placement (none if the tip frame is that link's own body frame).

    Raises ValueError for an unknown tip frame, a joint type not in `JOINT_TYPES` (naming the
    joint and its type), a joint without finite limits (URDF requires them; a model parsed
    from MJCF has no effort or velocity limits: set `model.upperEffortLimit` and
    `model.upperVelocityLimit` first, e.g. from the arm's data sheet), and duplicate link or
    joint names.
    """
    if not model.existFrame(tip_frame):
        raise ValueError(f"tip frame {tip_frame!r} is not a frame of the model {model.name!r}")
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    links = _link_names(model, base_link)
    robot = ET.Element("robot", name=name)
    robot.append(ET.Comment(" kinematics and inertias only: no meshes, visuals or collisions "))
    _add_link(robot, base_link, None)
    if not _is_zero(model.inertias[0]):
        _add_link(robot, f"{base_link}_inertia", model.inertias[0])
        _add_fixed_joint(robot, f"{base_link}_inertia_joint", base_link, f"{base_link}_inertia")
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        if _is_zero(inertia):
            inertia = pin.Inertia(MASSLESS_MASS, np.zeros(3), MASSLESS_MOMENT * np.eye(3))
        _add_link(robot, links[j], inertia)
        _add_moving_joint(robot, model, data, j, links)
    tip = model.frames[model.getFrameId(tip_frame)]
    parent = links[tip.parentJoint]
    if not (tip_frame == parent and tip.placement.isIdentity()):
        _add_link(robot, tip_frame, None)
        _add_fixed_joint(robot, f"{tip_frame}_fixed_joint", parent, tip_frame, tip.placement)
    _check_unique(robot)
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def write_urdf(
    path: str | Path, model: pin.Model, name: str, tip_frame: str, base_link: str = "base_link"
) -> Path:
    """Write `urdf_text(model, name, tip_frame, base_link)` to `path` atomically (see
    models.atomic): a reader never sees a partial file."""
    return write_text(path, urdf_text(model, name, tip_frame, base_link))


def _link_names(model: pin.Model, base_link: str) -> list[str]:
    """URDF link name of each joint's body; index 0 (the universe) is `base_link`."""
    names = [base_link]
    for j in range(1, model.njoints):
        at_joint = (
            f.name
            for f in model.frames
            if f.type == pin.FrameType.BODY and f.parentJoint == j and f.placement.isIdentity()
        )
        names.append(next(at_joint, f"{model.names[j]}_link"))
    return names


def _add_moving_joint(
    robot: ET.Element, model: pin.Model, data: pin.Data, j: int, links: list[str]
) -> None:
    """Joint j as a revolute or prismatic URDF joint, from its parent's link to its own."""
    name, kind = model.names[j], model.joints[j].shortname()
    if kind not in JOINT_TYPES:
        raise ValueError(
            f"joint {name!r} is a {kind}: the URDF exporter handles only "
            f"{', '.join(JOINT_TYPES)} (revolute and prismatic joints)"
        )
    joint_type = JOINT_TYPES[kind]
    iq, iv = model.joints[j].idx_q, model.joints[j].idx_v
    limits = {
        "lower": model.lowerPositionLimit[iq],
        "upper": model.upperPositionLimit[iq],
        "effort": model.upperEffortLimit[iv],
        "velocity": model.upperVelocityLimit[iv],
    }
    bad = [f"{key} = {float(value)}" for key, value in limits.items() if not np.isfinite(value)]
    if bad:
        raise ValueError(
            f"joint {name!r} has non-finite limits ({', '.join(bad)}): URDF requires finite "
            "position, effort and velocity limits; set them in the model first "
            "(model.lowerPositionLimit, upperPositionLimit, upperEffortLimit, upperVelocityLimit)"
        )
    # The motion subspace [linear; angular] of a one-axis joint is constant: its unit axis.
    S = np.asarray(data.joints[j].S).reshape(6)
    axis = S[3:] if joint_type == "revolute" else S[:3]
    joint = ET.SubElement(robot, "joint", name=name, type=joint_type)
    ET.SubElement(joint, "parent", link=links[model.parents[j]])
    ET.SubElement(joint, "child", link=links[j])
    _add_origin(joint, model.jointPlacements[j])
    ET.SubElement(joint, "axis", xyz=_numbers(axis))
    ET.SubElement(joint, "limit", {key: _number(value) for key, value in limits.items()})


def _add_fixed_joint(
    robot: ET.Element, name: str, parent: str, child: str, placement: pin.SE3 | None = None
) -> None:
    joint = ET.SubElement(robot, "joint", name=name, type="fixed")
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    _add_origin(joint, placement if placement is not None else pin.SE3.Identity())


def _add_link(robot: ET.Element, name: str, inertia: pin.Inertia | None) -> None:
    """A link; its <inertial> unless `inertia` is None or zero (a massless body)."""
    link = ET.SubElement(robot, "link", name=name)
    if inertia is None or _is_zero(inertia):
        return
    inertial = ET.SubElement(link, "inertial")
    _add_origin(inertial, pin.SE3(np.eye(3), np.asarray(inertia.lever)))
    ET.SubElement(inertial, "mass", value=_number(inertia.mass))
    I_c = np.asarray(inertia.inertia)  # about the centre of mass, in link axes [kg m^2]
    entries = {
        "ixx": (0, 0),
        "ixy": (0, 1),
        "ixz": (0, 2),
        "iyy": (1, 1),
        "iyz": (1, 2),
        "izz": (2, 2),
    }
    ET.SubElement(inertial, "inertia", {key: _number(I_c[ij]) for key, ij in entries.items()})


def _add_origin(element: ET.Element, placement: pin.SE3) -> None:
    """<origin xyz rpy>: the child frame's position [m] and orientation (URDF rpy [rad])."""
    rpy = pin.rpy.matrixToRpy(placement.rotation)
    ET.SubElement(element, "origin", xyz=_numbers(placement.translation), rpy=_numbers(rpy))


def _is_zero(inertia: pin.Inertia) -> bool:
    return not np.any(inertia.matrix())


def _check_unique(robot: ET.Element) -> None:
    for tag in ("link", "joint"):
        names = [element.get("name", "") for element in robot.findall(tag)]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"URDF {tag} names must be unique; repeated: {repeated}")


def _number(value: float) -> str:
    """Shortest text that reads back as the same float (no negative zero)."""
    return repr(float(value) + 0.0)


def _numbers(values: np.ndarray) -> str:
    return " ".join(_number(v) for v in values)
