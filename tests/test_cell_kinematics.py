"""Kinematics (Pinocchio) of the cell's arm and of a UR5: FK against independent analytic
models, Jacobians against finite differences, IK round trips, limits and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from cell import (
    JointLimitError,
    Kinematics,
    UnknownNameError,
    UnreachableTargetError,
    nominal_kinematics,
    ur5_kinematics,
)
from registration.rigid import pose_error

# -- independent analytic models ---------------------------------------------------------------


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    R = {
        "x": [[1, 0, 0], [0, c, -s], [0, s, c]],
        "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
        "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]],
    }[axis]
    T = np.eye(4)
    T[:3, :3] = R
    return T


def _trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def irb2400_fk(q: np.ndarray) -> np.ndarray:
    """IRB 2400 flange (z out of the flange) from its published dimensions [m]."""
    d1, a1, a2, a3, d4, d6 = 0.615, 0.100, 0.705, 0.135, 0.755, 0.085
    T = _rot("z", q[0]) @ _trans(a1, 0, d1) @ _rot("y", q[1]) @ _trans(0, 0, a2)
    T = T @ _rot("y", q[2]) @ _trans(0, 0, a3) @ _rot("x", q[3]) @ _trans(d4, 0, 0)
    T = T @ _rot("y", q[4]) @ _trans(d6, 0, 0) @ _rot("x", q[5])
    return T @ _rot("y", np.pi / 2)


def ur5_fk(q: np.ndarray) -> np.ndarray:
    """UR5 tool0 from the manufacturer's DH table, base_link = DH base turned by pi about z."""
    d = [0.089159, 0, 0, 0.10915, 0.09465, 0.0823]
    a = [0, -0.425, -0.39225, 0, 0, 0]
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    T = np.diag([-1.0, -1.0, 1.0, 1.0])
    for i in range(6):
        T = T @ _rot("z", q[i]) @ _trans(a[i], 0, d[i]) @ _rot("x", alpha[i])
    return T


ROBOTS = {
    "irb2400": (nominal_kinematics, irb2400_fk),
    "ur5": (ur5_kinematics, ur5_fk),
}


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request: pytest.FixtureRequest) -> tuple[Kinematics, object]:
    load, fk = ROBOTS[request.param]
    return load(), fk


def test_fk_matches_the_analytic_model(robot) -> None:
    kin, fk = robot
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = kin.random_configuration(rng)
        dr, dp = pose_error(kin.fk(q), fk(q))
        assert dp < 1e-9 and dr < 1e-9  # same numbers, different code: float precision


def test_irb2400_known_poses() -> None:
    kin = nominal_kinematics()
    # q = 0: flange at (a1 + d4 + d6, 0, d1 + a2 + a3), facing +x.
    T = kin.fk(np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [0.94, 0.0, 1.455], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [1.0, 0.0, 0.0], atol=1e-12)
    # home: wrist bent 90 deg, flange facing down, d6 below the wrist centre.
    T = kin.fk(np.array([0, 0, 0, 0, np.pi / 2, 0]))
    np.testing.assert_allclose(T[:3, 3], [0.855, 0.0, 1.37], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-12)


def test_joint_limits_are_radians() -> None:
    kin = nominal_kinematics()
    np.testing.assert_allclose(np.degrees(kin.upper), [180, 110, 65, 200, 120, 400])
    np.testing.assert_allclose(np.degrees(kin.lower), [-180, -100, -60, -200, -120, -400])


def test_jacobian_matches_finite_differences(robot) -> None:
    kin, _ = robot
    rng = np.random.default_rng(1)
    h = 1e-6
    for _ in range(5):
        q = kin.random_configuration(rng, margin=0.01)
        J = kin.jacobian(q)
        T0 = kin.fk(q)
        J_fd = np.zeros_like(J)
        for i in range(kin.nq):
            dq = np.zeros(kin.nq)
            dq[i] = h
            T1 = kin.fk(q + dq)
            J_fd[:3, i] = (T1[:3, 3] - T0[:3, 3]) / h
            dR = T1[:3, :3] @ T0[:3, :3].T
            J_fd[3:, i] = np.array(
                [dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]
            ) / (2 * h)
        np.testing.assert_allclose(J, J_fd, atol=1e-5)  # first-order differences, h = 1e-6


def test_ik_round_trips_random_targets(robot) -> None:
    kin, _ = robot
    rng = np.random.default_rng(2)
    seed = np.zeros(kin.nq) + 0.3
    solved = 0
    for _ in range(40):
        T = kin.fk(kin.random_configuration(rng, margin=0.05))
        result = kin.ik(T, seed)
        if result.success:
            solved += 1
            dr, dp = pose_error(kin.fk(result.q), T)
            assert dp < 1e-8 and dr < 1e-8
            assert np.all(result.q >= kin.lower) and np.all(result.q <= kin.upper)
    assert solved >= 39  # reachable by construction; at most one miss in 40


def test_ik_with_a_tcp_offset_and_the_current_seed() -> None:
    kin = nominal_kinematics()
    T_flange_tcp = np.eye(4)
    T_flange_tcp[:3, 3] = (0.01, 0.0, 0.2)
    q_now = np.array([0.1, 0.2, -0.1, 0.3, 1.2, -0.4])
    q_goal = q_now + 0.05
    T = kin.fk(q_goal) @ T_flange_tcp
    result = kin.ik(T, q_now, T_flange_tcp)
    assert result.success and result.seeds_tried == 1  # the current configuration suffices
    np.testing.assert_allclose(result.q, q_goal, atol=1e-8)  # nearest branch from the seed


def test_unreachable_target_names_target_and_residual() -> None:
    kin = nominal_kinematics()
    T = np.eye(4)
    T[:3, 3] = (3.0, 0.0, 1.0)  # 3 m away: beyond the 1.55 m reach
    with pytest.raises(UnreachableTargetError, match=r"3\.0000.*residual [0-9.]+") as info:
        kin.solve(T, np.zeros(6))
    residual = float(str(info.value).split("residual ")[1].split(" m")[0])
    assert residual > 1.0  # at least 3 - 1.55 - 0.3 m remain
    assert isinstance(info.value, ValueError)


def test_targets_outside_joint_limits_are_refused() -> None:
    kin = nominal_kinematics()
    with pytest.raises(JointLimitError, match=r"joint3 = 1\.5 outside \[-1\.0472, 1\.13446\]"):
        kin.check_limits(np.array([0, 0, 1.5, 0, 0, 0]))
    # A target made with J3 = 86 deg (limit 65 deg): IK answers only within the limits.
    q_out = np.array([0.2, 0.3, 1.5, 0.4, 0.8, 0.1])
    T = kin.fk(q_out)
    result = kin.ik(T, np.zeros(6))
    assert np.all(result.q >= kin.lower) and np.all(result.q <= kin.upper)
    dr, dp = pose_error(kin.fk(result.q), T)
    assert (result.success and dp < 1e-8 and dr < 1e-8) or (not result.success and dp + dr > 1e-6)


def test_unknown_frame_lists_the_frames() -> None:
    kin = nominal_kinematics()
    with pytest.raises(UnknownNameError, match=r"available frames: .*flange"):
        kin.fk(np.zeros(6), "no_such_frame")


def test_missing_robot_files_are_refused(tmp_path) -> None:
    from cell import CellConfigError

    with pytest.raises(CellConfigError, match="does not exist"):
        Kinematics.from_mjcf(tmp_path / "no_robot.xml")
    with pytest.raises(CellConfigError, match="does not exist"):
        Kinematics.from_urdf(tmp_path / "no_robot.urdf", "tool0")
