"""The cell's model files: generated files up to date, both parsers agree, the scene steps
without warnings under random controls, the arm moves freely, servos track."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin

from cell.sim import CellConfig
from cell.sim.real import build_real_model
from cell.sim.selfcheck import fk_max_error, random_controls_warnings
from cell.sim.simulation import Simulation
from cell.trajectory import joint_trajectory
from models.robot import (
    JOINT_NAMES,
    JOINT_SPEED,
    Q_HOME,
    ROBOT_PATH,
    SCENE_PATH,
    ArmGeometry,
    arm_xml,
    scene_xml,
)


def test_files_on_disk_match_the_generators() -> None:
    assert ROBOT_PATH.read_text() == arm_xml()
    assert SCENE_PATH.read_text() == scene_xml()


def test_scene_file_compiles_and_includes_the_robot() -> None:
    m = mujoco.MjModel.from_xml_path(str(SCENE_PATH))
    assert [m.joint(i).name for i in range(6)] == list(JOINT_NAMES)
    np.testing.assert_allclose(m.key("home").qpos[:6], Q_HOME)
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_pinocchio_reads_the_robot_only_file() -> None:
    model = pin.buildModelFromMJCF(str(ROBOT_PATH))
    assert model.nq == 6
    assert model.existFrame("flange")
    assert [model.names[j] for j in range(1, 7)] == list(JOINT_NAMES)


def test_mujoco_and_pinocchio_agree_on_forward_kinematics() -> None:
    from cell import nominal_kinematics

    assert fk_max_error(nominal_kinematics(), n=200, seed=3) < 1e-12


def test_random_controls_raise_no_warnings() -> None:
    assert random_controls_warnings(seed=5, seconds=2.0) == 0


def test_perturbed_geometry_changes_the_flange_by_the_given_amounts() -> None:
    # Lengthening d4 by 1 mm moves the flange at q = 0 by 1 mm along x (forearm along x).
    g = ArmGeometry().perturbed([0, 0, 0, 0, 1e-3, 0], np.zeros(6))
    m0 = mujoco.MjModel.from_xml_string(arm_xml())
    m1 = mujoco.MjModel.from_xml_string(arm_xml(g))
    d0, d1 = mujoco.MjData(m0), mujoco.MjData(m1)
    mujoco.mj_kinematics(m0, d0)
    mujoco.mj_kinematics(m1, d1)
    s = m0.site("flange").id
    np.testing.assert_allclose(d1.site_xpos[s] - d0.site_xpos[s], [1e-3, 0, 0], atol=1e-12)
    # A joint-1 zero offset of 1 mrad turns the flange about z by 1 mrad (0.94 mm at 0.94 m).
    g = ArmGeometry().perturbed(np.zeros(6), [1e-3, 0, 0, 0, 0, 0])
    m2 = mujoco.MjModel.from_xml_string(arm_xml(g))
    d2 = mujoco.MjData(m2)
    mujoco.mj_kinematics(m2, d2)
    expected = [0.94 * np.cos(1e-3), 0.94 * np.sin(1e-3), 1.455]
    np.testing.assert_allclose(d2.site_xpos[s], expected, atol=1e-12)


def test_the_arm_moves_freely_and_tracks() -> None:
    """Large joint moves: no contact between arm bodies, set-points reached within 1e-6 rad."""
    sim = Simulation(build_real_model(CellConfig().ideal()))
    m, d = sim.model, sim.data
    arm_bodies = {
        m.body(n).id for n in ("base", "link1", "link2", "link3", "link4", "link5", "link6")
    }
    targets = [
        np.array([1.0, 0.6, 0.9, 2.5, -1.8, 4.0]),  # forearm folded down, wrist twisted
        np.array([-2.5, -0.8, -0.9, -3.0, 2.0, -6.0]),
        np.array([2.5, 1.2, 1.0, 0.0, 1.9, 0.0]),  # reaching far out and low, away from the table
    ]
    for q1 in targets:
        q, qd = joint_trajectory(sim.arm_setpoint(), q1, JOINT_SPEED, sim.dt)
        for k in range(len(q)):
            d.ctrl[sim.arm_act] = q[k] + sim.arm_ff * qd[k]
            mujoco.mj_step(m, d)
            for c in d.contact[: d.ncon]:
                b1, b2 = m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]
                assert not (b1 in arm_bodies and b2 in arm_bodies), "arm self-contact"
        sim.settle(0.5)
        np.testing.assert_allclose(sim.arm_q(), q1, atol=1e-6)
    assert sim.warnings() == 0
