"""Motion: trajectories within the speed limits, straight TCP lines, and the conventions of
the transforms (MuJoCo wxyz quaternions)."""

from __future__ import annotations

import mujoco
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from cell.sim import CellConfig, make_cell
from cell.trajectory import joint_trajectory, straight_path
from models.robot import JOINT_SPEED
from registration.rigid import R_to_quat_wxyz, invert, make_T, quat_wxyz_to_R, rotvecs_to_R

R_DOWN = np.diag([1.0, -1.0, -1.0])


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
    st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
    st.floats(0.1, 1.0),
)
def test_joint_trajectory_respects_speed_limits(q0: list, q1: list, speed: float) -> None:
    q0, q1 = np.array(q0), np.array(q1)
    dt = 0.002
    q, qd = joint_trajectory(q0, q1, JOINT_SPEED, dt, speed)
    np.testing.assert_array_equal(q[-1], q1)
    assert np.all(np.abs(qd) <= speed * JOINT_SPEED * (1 + 1e-9))
    # Positions and velocities agree (finite differences of the samples, O(dt^2)).
    path = np.vstack([q0, q])
    fd = np.diff(path, axis=0) / dt
    assert np.all(np.abs(fd) <= speed * JOINT_SPEED * (1 + 1e-6) + 1e-9)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1)
)
def test_quaternions_follow_mujoco(v: list) -> None:
    q = np.array(v) / np.linalg.norm(v)
    R_mj = np.zeros(9)
    mujoco.mju_quat2Mat(R_mj, q)
    R = quat_wxyz_to_R(q)
    np.testing.assert_allclose(R, R_mj.reshape(3, 3), atol=1e-12)
    assert abs(np.linalg.det(R) - 1.0) < 1e-12
    q_back = R_to_quat_wxyz(R)
    # The same rotation: q and -q (sign ambiguity only).
    assert min(np.abs(q_back - q).max(), np.abs(q_back + q).max()) < 1e-9
    assert q_back[0] >= 0


def test_quaternions_and_rotation_vectors_agree_with_scipy() -> None:
    """Every branch of the quaternion's extraction (the trace, or one of the diagonal's
    entries, the largest: half turns about x, y and z) and Rodrigues' formula (a zero
    vector included), against scipy's Rotation, the reference; tolerance 1e-12."""
    rng = np.random.default_rng(5)
    turns = [Rotation.from_rotvec(np.pi * e) for e in np.eye(3)]
    near = [Rotation.from_rotvec((np.pi - 1e-3) * v / np.linalg.norm(v))
            for v in rng.normal(size=(30, 3))]  # fmt: skip
    for r in [*turns, *near, *Rotation.random(300, random_state=6)]:
        expected = r.as_quat(scalar_first=True)
        expected = expected if expected[0] >= 0 else -expected
        got = R_to_quat_wxyz(r.as_matrix())
        assert min(np.abs(got - expected).max(), np.abs(got + expected).max()) < 1e-12
    vectors = np.vstack([np.zeros(3), rng.normal(size=(200, 3)) * rng.uniform(0, 3, (200, 1))])
    np.testing.assert_allclose(
        rotvecs_to_R(vectors), Rotation.from_rotvec(vectors).as_matrix(), atol=1e-12
    )


def test_inverse_transform() -> None:
    T = make_T(quat_wxyz_to_R(np.array([0.5, 0.5, -0.5, 0.5])), np.array([0.1, -0.2, 0.3]))
    np.testing.assert_allclose(invert(T) @ T, np.eye(4), atol=1e-15)


def test_straight_path_interpolates_pose() -> None:
    T0 = make_T(np.eye(3), np.zeros(3))
    T1 = make_T(quat_wxyz_to_R(np.array([np.cos(0.5), 0, 0, np.sin(0.5)])), np.array([1.0, 2, 3]))
    mid = straight_path(T0, T1, np.array([0.5]))[0]
    np.testing.assert_allclose(mid[:3, 3], [0.5, 1.0, 1.5])
    np.testing.assert_allclose(
        R_to_quat_wxyz(mid[:3, :3]), [np.cos(0.25), 0, 0, np.sin(0.25)], atol=1e-12
    )


def test_linear_move_keeps_the_tcp_on_the_line() -> None:
    """Sampled while moving (laser stamps): the TCP stays within 0.1 mm of the segment."""
    controller, _ = make_cell(CellConfig(seed=21).ideal())
    controller.change_tool("laser")
    a, b = np.array([0.9, -0.3, 0.8]), np.array([1.3, 0.3, 0.65])
    controller.move_linear(make_T(R_DOWN, a))
    readings = controller.scan_linear(make_T(R_DOWN, b), speed_m_s=0.25, period_s=0.01)
    T_tcp = controller.T_flange_tcp()
    p = np.array([(controller.kinematics.fk(r.q_measured) @ T_tcp)[:3, 3] for r in readings])
    u = (b - a) / np.linalg.norm(b - a)
    along = (p - a) @ u
    off_line = np.linalg.norm((p - a) - along[:, None] * u, axis=1)
    assert off_line.max() < 1e-4
    assert along.min() > -1e-4 and along.max() < np.linalg.norm(b - a) + 1e-4
    assert along[-1] > np.linalg.norm(b - a) - 1e-3  # it got there
