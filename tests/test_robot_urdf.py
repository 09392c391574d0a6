"""URDF export (models.robot.urdf): the written URDF, read back by Pinocchio's and MuJoCo's own
URDF parsers, against the Pinocchio model it was written from (built from the cell's MJCF, from
perturbed arm geometry, from the UR5's URDF, or joint by joint in code)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from cell import Kinematics, nominal_kinematics, ur5_kinematics
from models.robot import JOINT_SPEED, ArmGeometry
from models.robot.urdf import MASSLESS_MASS, urdf_text, write_urdf

TOL = 1e-9
#: Effort limits [N m] given to the cell's arm for the export (its MJCF carries no effort or
#: velocity limits; the velocity limits are the arm's data-sheet speeds, JOINT_SPEED).
ARM_EFFORT = np.array([4000.0, 4000.0, 2500.0, 600.0, 600.0, 300.0])


def _with_arm_limits(model: pin.Model) -> pin.Model:
    """A copy of a model of the cell's arm with effort and velocity limits."""
    model = pin.Model(model)
    model.upperEffortLimit = ARM_EFFORT
    model.upperVelocityLimit = JOINT_SPEED
    return model


def _perturbed_geometry() -> ArmGeometry:
    rng = np.random.default_rng(7)
    return ArmGeometry().perturbed(rng.uniform(-3e-3, 3e-3, 6), rng.uniform(-3e-3, 3e-3, 6))


def _unit(v: tuple[float, float, float]) -> np.ndarray:
    return np.asarray(v, dtype=float) / np.linalg.norm(v)


def _mixed_model() -> pin.Model:
    """A chain with every joint kind the exporter handles (aligned and unaligned revolute and
    prismatic joints, negative axis components), placements near the roll-pitch-yaw gimbal lock
    (pitch = +-pi/2), full inertia tensors and one massless moving body; tip frame `tip`."""
    rng = np.random.default_rng(11)
    joints = (
        pin.JointModelRZ(),
        pin.JointModelRevoluteUnaligned(_unit((0.6, 0.0, -0.8))),
        pin.JointModelPX(),
        pin.JointModelRY(),
        pin.JointModelPrismaticUnaligned(_unit((-0.2, 0.3, 0.9))),
        pin.JointModelRevoluteUnaligned(_unit((1.0, 2.0, 3.0))),
        pin.JointModelRX(),
    )
    pitches = (0.3, np.pi / 2 - 1e-9, -np.pi / 2, np.pi / 2, -1.0, np.pi / 2 - 1e-6, 2.0)
    model = pin.Model()
    model.name = "mixed"
    joint = frame = 0
    for i, (joint_model, pitch) in enumerate(zip(joints, pitches, strict=True)):
        roll, yaw = rng.uniform(-np.pi, np.pi, 2)
        placement = pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), rng.uniform(-0.3, 0.3, 3))
        prismatic = isinstance(joint_model, pin.JointModelPX | pin.JointModelPrismaticUnaligned)
        travel = np.array([0.2 if prismatic else 2.5])
        joint = model.addJoint(
            joint,
            joint_model,
            placement,
            f"j{i}",
            np.array([50.0 + i]),
            np.array([1.0 + 0.1 * i]),
            -travel,
            travel + 0.1,
        )
        if i != 2:  # body 2 stays massless
            R = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
            half = rng.uniform(0.02, 0.2, 3)
            mass = rng.uniform(0.5, 20.0)
            box = mass / 3.0 * (np.sum(half**2) - half**2)  # principal moments [kg m^2]
            inertia = pin.Inertia(mass, rng.uniform(-0.1, 0.1, 3), R @ np.diag(box) @ R.T)
            model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
        frame = model.addBodyFrame(f"body{i}", joint, pin.SE3.Identity(), frame)
    tip = pin.SE3(pin.rpy.rpyToMatrix(0.4, -np.pi / 2, 1.1), np.array([0.0, 0.05, 0.1]))
    model.addFrame(pin.Frame("tip", joint, frame, tip, pin.FrameType.OP_FRAME))
    return model


def _arm(arm: str) -> tuple[pin.Model, str]:
    """The model to export and its tip frame; every one is built without the exporter."""
    if arm == "nominal":
        return _with_arm_limits(nominal_kinematics().model), "flange"
    if arm == "perturbed":
        return _with_arm_limits(Kinematics.from_geometry(_perturbed_geometry()).model), "flange"
    if arm == "ur5":
        kinematics = ur5_kinematics()
        return kinematics.model, kinematics.tip_frame
    return _mixed_model(), "tip"


ARMS = ("nominal", "perturbed", "ur5", "mixed")


def _tip_pose(model: pin.Model, data: pin.Data, tip: str, q: np.ndarray) -> pin.SE3:
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId(tip)]


def _pose_errors(T_a: pin.SE3, T_b: pin.SE3) -> tuple[float, float]:
    """Position [m] and rotation [rad] differences of two poses."""
    dp = float(np.linalg.norm(T_a.translation - T_b.translation))
    dr = float(np.linalg.norm(pin.log3(T_a.rotation.T @ T_b.rotation)))
    return dp, dr


def _configurations(model: pin.Model, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(model.lowerPositionLimit, model.upperPositionLimit, (n, model.nq))


@pytest.mark.parametrize("arm", ARMS)
def test_pinocchio_reads_back_the_same_arm(arm: str) -> None:
    model, tip = _arm(arm)
    text = urdf_text(model, arm, tip)
    back = pin.buildModelFromXML(text)

    assert back.name == arm
    assert list(back.names) == list(model.names)
    assert [j.nq for j in back.joints] == [j.nq for j in model.joints]
    for limit in (
        "lowerPositionLimit",
        "upperPositionLimit",
        "upperEffortLimit",
        "upperVelocityLimit",
    ):
        np.testing.assert_array_equal(getattr(back, limit), getattr(model, limit), err_msg=limit)

    # Inertias body by body (the base's on the universe), as 6x6 spatial inertias.
    # A massless moving body comes back with the exporter's tiny stand-in inertia.
    for j in range(model.njoints):
        expected = model.inertias[j].matrix()
        if j > 0 and not np.any(expected):
            assert back.inertias[j].mass == MASSLESS_MASS
        np.testing.assert_allclose(
            back.inertias[j].matrix(), expected, rtol=0.0, atol=TOL, err_msg=f"body {j}"
        )
    # Total mass: of the moving bodies (Pinocchio's) and with the fixed base.
    assert pin.computeTotalMass(back) == pytest.approx(pin.computeTotalMass(model), abs=TOL)
    mass = sum(model.inertias[j].mass for j in range(model.njoints))
    assert sum(back.inertias[j].mass for j in range(back.njoints)) == pytest.approx(mass, abs=TOL)

    data, back_data = model.createData(), back.createData()
    for q in _configurations(model, 50, seed=1):
        dp, dr = _pose_errors(_tip_pose(model, data, tip, q), _tip_pose(back, back_data, tip, q))
        assert dp < TOL and dr < TOL, (q, dp, dr)


def _mujoco_model(text: str) -> mujoco.MjModel:
    """MuJoCo's compile of the URDF with the fixed links kept as bodies.

    MuJoCo fuses links attached by fixed joints into their parents when it compiles a URDF
    (compiler `fusestatic`, on by default for URDF): the tip link would vanish into the last
    link. A <mujoco><compiler fusestatic="false"/></mujoco> element, MuJoCo's extension of
    URDF (other parsers ignore it), is inserted after <robot> so the tip stays a body whose
    pose MuJoCo computes itself from the fixed joint's origin.
    """
    start = text.index("<robot")
    end = text.index(">", start) + 1
    keep_fixed = '\n  <mujoco><compiler fusestatic="false"/></mujoco>'
    return mujoco.MjModel.from_xml_string(text[:end] + keep_fixed + text[end:])


@pytest.mark.parametrize("arm", ARMS)
def test_mujoco_compiles_the_urdf_to_the_same_kinematics(arm: str) -> None:
    model, tip = _arm(arm)
    mj = _mujoco_model(urdf_text(model, arm, tip))
    mj_data = mujoco.MjData(mj)
    data = model.createData()
    names = list(model.names)[1:]
    assert mj.njnt == len(names)
    for j, name in enumerate(names, start=1):
        lower, upper = mj.joint(name).range
        iq = model.joints[j].idx_q
        assert (lower, upper) == (model.lowerPositionLimit[iq], model.upperPositionLimit[iq])
    for q in _configurations(model, 5, seed=2):
        for j, name in enumerate(names, start=1):
            mj_data.qpos[mj.joint(name).qposadr[0]] = q[model.joints[j].idx_q]
        mujoco.mj_kinematics(mj, mj_data)
        body = mj_data.body(tip)
        T_mujoco = pin.SE3(body.xmat.reshape(3, 3).copy(), body.xpos.copy())
        dp, dr = _pose_errors(_tip_pose(model, data, tip, q), T_mujoco)
        assert dp < TOL and dr < TOL, (q, dp, dr)


def test_write_urdf_gives_a_file_the_kinematics_loads(tmp_path: Path) -> None:
    model, _ = _arm("perturbed")
    path = write_urdf(tmp_path / "irb2400.urdf", model, "irb2400", "flange")
    assert [p.name for p in tmp_path.iterdir()] == ["irb2400.urdf"]  # no temporary file left
    robot = ET.parse(path).getroot()
    assert not robot.findall(".//mesh") and not robot.findall(".//visual")
    assert not robot.findall(".//collision")
    # The root link carries no inertia (kdl_parser does not support one); the base's does.
    children = {child.get("link") for child in robot.iter("child")}
    (root,) = [link for link in robot.iter("link") if link.get("name") not in children]
    assert root.get("name") == "base_link" and root.find("inertial") is None
    assert robot.find("link[@name='base_link_inertia']/inertial/mass").get("value") == "50.0"
    loaded = Kinematics.from_urdf(path, "flange")
    truth = Kinematics.from_geometry(_perturbed_geometry())
    for q in _configurations(model, 5, seed=3):
        np.testing.assert_allclose(loaded.fk(q), truth.fk(q), rtol=0.0, atol=TOL)


def test_a_joint_type_the_exporter_does_not_handle_is_named() -> None:
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "turn")
    joint = model.addJoint(joint, pin.JointModelSpherical(), pin.SE3.Identity(), "wrist_ball")
    model.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    model.upperEffortLimit[:] = 1.0
    model.upperVelocityLimit[:] = 1.0
    model.lowerPositionLimit[:] = -1.0
    model.upperPositionLimit[:] = 1.0
    with pytest.raises(ValueError, match=r"'wrist_ball' is a JointModelSpherical"):
        urdf_text(model, "ball", "tip")


def test_missing_limits_and_unknown_tip_are_refused() -> None:
    model = nominal_kinematics().model  # parsed from MJCF: no effort or velocity limits
    with pytest.raises(ValueError, match=r"joint 'joint1' has non-finite limits \(effort = inf"):
        urdf_text(model, "irb2400", "flange")
    with pytest.raises(ValueError, match="tip frame 'tool0' is not a frame"):
        urdf_text(_with_arm_limits(model), "irb2400", "tool0")
