"""The cell's arm from a file: the UR5 of example-robot-data as the cell simulates it and as
the planner models it, its kinematic deviations, and every robot file the cell must refuse."""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from cell.arm_file import DEFAULT_SPEED_RAD_S, load_arm_model
from cell.cell_errors import CellConfigError
from cell.file_robot import JointLimits, robot_from_file
from cell.irb2400_arm import irb2400
from cell.robots import make_robot
from cell.sim import CellConfig, make_cell
from cell.ur5_arm import ur5, ur5_urdf
from cell.virtual import VirtualCell
from models.robot import RACK_POS
from scenarios.outputs.toolchain_exports import write_robot_urdf

#: MuJoCo and Pinocchio agree to rounding on the same kinematic chain [m].
FK_TOL_M = 1e-9


def _urdf_without_meshes() -> str:
    """The UR5's URDF with its visual and collision elements (package:// meshes) removed."""
    return re.sub(r"<(visual|collision)>.*?</\1>", "", ur5_urdf().read_text(), flags=re.S)


def test_the_planner_reads_the_ur5_as_mujoco_compiles_its_urdf() -> None:
    """Ground truth: MuJoCo's own URDF compiler on the example-robot-data file."""
    m = mujoco.MjModel.from_xml_string(_urdf_without_meshes())
    d = mujoco.MjData(m)
    kin = ur5(mount_xyz=(0.0, 0.0, 0.0)).kinematics()
    rng = np.random.default_rng(3)
    body = m.body("wrist_3_link").id
    for _ in range(50):
        q = kin.random_configuration(rng)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        T = kin.fk(q, "wrist_3_link")
        assert np.linalg.norm(d.xpos[body] - T[:3, 3]) < FK_TOL_M
        assert np.abs(d.xmat[body].reshape(3, 3) - T[:3, :3]).max() < FK_TOL_M


@pytest.mark.parametrize("deviated", [False, True])
def test_the_simulated_ur5_is_the_planned_one(deviated: bool) -> None:
    """The MJCF the cell simulates (mounted, and with drawn deviations) puts its flange site
    where Pinocchio's model of the same arm puts the flange."""
    robot = ur5()
    d_arm = robot.draw_deviations(np.random.default_rng(1), 2e-3, 2e-3) if deviated else None
    m = mujoco.MjModel.from_xml_string(robot.mjcf(d_arm))
    d = mujoco.MjData(m)
    kin = robot.kinematics(d_arm)
    site = m.site("flange").id
    rng = np.random.default_rng(4)
    for _ in range(50):
        q = kin.random_configuration(rng)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        T = kin.fk(q)
        assert np.linalg.norm(d.site_xpos[site] - T[:3, 3]) < FK_TOL_M
        assert np.abs(d.site_xmat[site].reshape(3, 3) - T[:3, :3]).max() < FK_TOL_M


def test_the_mount_places_the_arm_and_the_deviations_move_the_flange() -> None:
    here, there = ur5(mount_xyz=(0.0, 0.0, 0.0)), ur5(mount_xyz=(0.5, -0.2, 0.45))
    q = here.q_home
    shift = there.kinematics().fk(q)[:3, 3] - here.kinematics().fk(q)[:3, 3]
    np.testing.assert_allclose(shift, [0.5, -0.2, 0.45], atol=1e-12)
    np.testing.assert_allclose(there.T_world_base[:3, 3], [0.5, -0.2, 0.45])
    # 24 parameters: a zero offset and an axis position per joint.
    assert len(there.parameters) == 24 and there.lengths.sum() == 18
    d = np.zeros(24)
    d[there.parameters.index("z2")] = 1e-3
    moved = there.kinematics(d).fk(q)[:3, 3] - there.kinematics().fk(q)[:3, 3]
    assert np.linalg.norm(moved) == pytest.approx(1e-3, rel=1e-6)  # a pure shift of joint 2


def test_a_ur5_cell_runs_its_arm_where_it_is_commanded() -> None:
    """The UR5 cell with the rack moved in: a tool change and a move; the real flange
    (truth) is within the arm's deviations of where the nominal model puts it."""
    controller, truth = make_cell(CellConfig(seed=2, robot=ur5(), rack_xyz=(0.2, -0.8, -0.1)))
    assert controller.robot.name == "ur5" and not controller.robot.rapid
    controller.change_tool("laser")
    assert controller.tool_in_hand == "laser"
    q = controller.q_home + np.array([0.2, -0.1, 0.1, 0.0, 0.1, 0.3])
    controller.move_joints(q)
    np.testing.assert_allclose(truth.q(), q, atol=2e-3)  # servo tracking
    real = truth.kinematics().fk(truth.q())[:3, 3]
    gap = np.linalg.norm(real - controller.kinematics.fk(truth.q())[:3, 3])
    assert 1e-5 < gap < 3e-3  # the real arm is not the nominal one


def test_an_arm_bolted_at_floor_level_turns_clear_of_the_floor(tmp_path: Path) -> None:
    """An IRB 2400-class arm from its URDF (joint 1's origin at the foot of its base),
    mounted at floor level: its first link's capsule reaches a radius (5 cm) below that
    origin, into the floor; the link that turns on the base bolted there does not meet the
    floor, in the virtual cell (the planner's checks, 10 mm margin) or in the real one
    (turning joint 1 raises no supervision stop)."""
    arm = irb2400()
    urdf = write_robot_urdf(tmp_path, arm, arm.kinematics(), None)[0]  # what a run writes
    home = np.deg2rad([0.0, 0.0, 0.0, 0.0, 90.0, 0.0])
    robot = robot_from_file(urdf, "flange", q_home=home, vendor="abb")
    cell = VirtualCell.of(robot, RACK_POS)
    for turn in (0.0, 1.0, -2.0):
        cell.set_joints(robot.q_home + np.array([turn, 0, 0, 0, 0, 0]))
        assert [c for c in cell.contacts(0.01) if "link1" in (c.body, c.other)] == []
    controller, truth = make_cell(CellConfig(seed=1, robot=robot))
    q = controller.q_home + np.array([0.5, 0, 0, 0, 0, 0])
    controller.move_joints(q)
    np.testing.assert_allclose(truth.q(), q, atol=2e-3)
    assert controller.events == []


# -- files the cell refuses -------------------------------------------------------------------
def test_a_missing_or_foreign_robot_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CellConfigError, match=r"robot file not found: .*nowhere\.urdf"):
        load_arm_model(tmp_path / "nowhere.urdf", "tool0")
    step = tmp_path / "arm.step"
    step.write_text("ISO-10303-21;")
    with pytest.raises(CellConfigError, match=r"unknown format '\.step'; valid: \.urdf, \.xml"):
        load_arm_model(step, "tool0")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(CellConfigError, match=r"broken\.urdf: cannot be read as a robot"):
        load_arm_model(broken, "tool0")


def test_a_robot_without_the_named_flange_is_refused(tmp_path: Path) -> None:
    arm = tmp_path / "ur5.urdf"
    arm.write_text(_urdf_without_meshes())
    with pytest.raises(CellConfigError, match=r"no frame 'flange_link' for the flange; its "
                       r"frames are .*'tool0'"):  # fmt: skip
        load_arm_model(arm, "flange_link")


def test_a_robot_with_other_than_six_joints_is_refused(tmp_path: Path) -> None:
    """The UR5 with its last joint fixed: five revolute joints."""
    text = _urdf_without_meshes().replace(
        '<joint name="wrist_3_joint" type="revolute">', '<joint name="wrist_3_joint" type="fixed">'
    )
    arm = tmp_path / "five.urdf"
    arm.write_text(text)
    with pytest.raises(CellConfigError, match=r"needs a 6-axis arm .* has 5 position variables"):
        load_arm_model(arm, "tool0")


def test_bad_robot_choices_are_refused() -> None:
    with pytest.raises(CellConfigError, match="irb2400 is built in"):
        make_robot("irb2400", mount_xyz=(1.0, 0.0, 0.0))
    with pytest.raises(CellConfigError, match="name its flange frame"):
        make_robot(str(ur5_urdf()))
    with pytest.raises(CellConfigError, match=r"home .* outside the joint limits"):
        make_robot("ur5", q_home=np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(CellConfigError, match=r"joint ranges .* within the arm's"):
        limits = JointLimits(ranges_rad=(np.full(6, -7.0), np.full(6, 7.0)))
        robot_from_file(ur5_urdf(), "tool0", joint_limits=limits)
    with pytest.raises(CellConfigError, match="deviations must be 12 finite numbers"):
        irb2400().kinematics(np.zeros(24))


def test_a_robot_only_mjcf_file_is_read_as_the_built_in_arm() -> None:
    """The built-in arm's own MJCF, given as a file: the efforts are its actuators' force
    ranges (the data sheet's torques), the speeds (MJCF has none) the cautious defaults
    unless given; the same flange at random joints."""
    from models.robot import JOINT_SPEED, JOINT_TORQUE, ROBOT_PATH

    read = make_robot(str(ROBOT_PATH), flange="flange")
    np.testing.assert_array_equal(read.joint_effort, JOINT_TORQUE)
    np.testing.assert_array_equal(read.joint_speed, DEFAULT_SPEED_RAD_S)
    speed, effort = np.array(JOINT_SPEED), np.array(JOINT_TORQUE)
    as_file = make_robot(str(ROBOT_PATH), flange="flange", speed=speed, effort=effort)
    assert as_file.name == "irb2400" and len(as_file.parameters) == 24
    built_in = irb2400().kinematics()
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = built_in.random_configuration(rng)
        np.testing.assert_allclose(as_file.kinematics().fk(q), built_in.fk(q), atol=FK_TOL_M)


def test_an_mjcf_arm_without_force_ranges_needs_its_efforts(tmp_path: Path) -> None:
    """Six hinges and no actuators: nothing states the joints' efforts."""
    bodies = "".join(
        f'<body name="l{k}" pos="0 0 0.1"><joint name="j{k}" axis="{axis}" range="-3 3"/>'
        '<inertial pos="0 0 0.05" mass="1" diaginertia="0.01 0.01 0.01"/>'
        for k, axis in enumerate(("0 0 1", "0 1 0", "0 1 0", "0 0 1", "0 1 0", "0 0 1"))
    )
    arm = tmp_path / "bare.xml"
    arm.write_text(f"<mujoco><worldbody>{bodies}{'</body>' * 6}</worldbody></mujoco>")
    with pytest.raises(
        CellConfigError, match=r"bare\.xml: every joint needs .*cell\.robot\.effort_nm"
    ):
        make_robot(str(arm), flange="l5")


def test_a_gripper_joint_beyond_the_flange_is_locked(tmp_path: Path) -> None:
    """The UR5 with a finger joint on its flange: seven joints in the file, six that move
    the flange; the arm is the six, its flange where the file's six put it."""
    finger = (
        '<link name="finger"/><joint name="finger_joint" type="prismatic">'
        '<parent link="tool0"/><child link="finger"/><axis xyz="0 1 0"/>'
        '<limit lower="0" upper="0.04" effort="10" velocity="0.1"/></joint></robot>'
    )
    arm = tmp_path / "ur5_finger.urdf"
    arm.write_text(_urdf_without_meshes().replace("</robot>", finger))
    six = load_arm_model(ur5_urdf(), "tool0")
    seven = load_arm_model(arm, "tool0")
    assert seven.nq == 6
    q = np.array([0.3, -1.1, 1.4, -0.7, -1.2, 0.5])
    d6, d7 = six.createData(), seven.createData()
    import pinocchio as pin

    pin.framesForwardKinematics(six, d6, q)
    pin.framesForwardKinematics(seven, d7, q)
    np.testing.assert_allclose(
        d7.oMf[seven.getFrameId("tool0")].homogeneous,
        d6.oMf[six.getFrameId("tool0")].homogeneous,
        atol=1e-12,
    )


def test_a_flange_frame_off_the_wrist_axis_is_refused(tmp_path: Path) -> None:
    """The UR5's wrist_3_link frame has its z axis across joint 6's axis: a tool mounted
    along it would stick out sideways."""
    arm = tmp_path / "ur5.urdf"
    arm.write_text(_urdf_without_meshes())
    with pytest.raises(CellConfigError, match=r"'wrist_3_link' has its z axis 90 deg off the "
                       r"last joint's axis.*cell\.robot\.flange.*'tool0'"):  # fmt: skip
        load_arm_model(arm, "wrist_3_link")


def test_a_warm_arm_s_links_grow_by_its_strain() -> None:
    """The built-in arm grown by a strain e: every link length times 1 + e, so the flange's
    position in the base frame, at any joints, is the cold arm's times 1 + e (1e-12 m; the
    arm's base is the cell's origin). A file arm (the UR5) grows each joint's axis position
    in its parent but joint 1's (its mount). The real cell's arm carries the growth on top of
    the kinematic errors it drew (`ArmErrors.thermal_strain`), and a strain of zero leaves
    them to the bit."""
    from cell.sim import ArmErrors
    from cell.sim.real import draw_real_parameters

    strain = 4.0e-4
    arm = irb2400()
    cold, warm = arm.kinematics(), arm.kinematics(arm.grown(strain))
    for q in np.random.default_rng(0).uniform(-1.0, 1.0, (5, 6)):
        expected = cold.fk(q)[:3, 3] * (1.0 + strain)
        assert np.max(np.abs(warm.fk(q)[:3, 3] - expected)) < 1e-12
    ur = ur5()
    assert ur.nominal_lengths is not None and not ur.nominal_lengths[:4].any()
    assert np.count_nonzero(ur.nominal_lengths) >= 5
    for robot in (arm, ur):
        base = CellConfig(seed=5, robot=robot)
        drawn = draw_real_parameters(base).deviations
        assert np.array_equal(
            draw_real_parameters(
                CellConfig(seed=5, robot=robot, arm=ArmErrors(thermal_strain=0.0))
            ).deviations,
            drawn,
        )
        grown = CellConfig(seed=5, robot=robot, arm=ArmErrors(thermal_strain=strain))
        assert np.array_equal(draw_real_parameters(grown).deviations, drawn + robot.grown(strain))
