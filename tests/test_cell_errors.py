"""The real cell's errors beyond the arm's kinematics: each, switched on alone in an
otherwise exact cell, does what its physics says, measured on the truth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cell.sim import CellConfig, DriveErrors, TableErrors, ToolErrors, make_cell
from cell.sim.devices import table_profile
from models.robot import TABLE_TOP_POS, TABLE_TRAVEL
from registration.rigid import pose_error

#: A pose with the forearm out over the table (joints 2 and 3 carry the arm's weight).
Q_OUT = np.array([0.1, 0.5, 0.2, 0.3, 0.9, 0.0])


def _exact(**errors: object) -> CellConfig:
    return replace(CellConfig(seed=21).ideal(), **errors)


def _sag_m(stiffness: tuple[float, float]) -> float:
    """How far the real flange hangs below where the motors put it [m], laser in hand."""
    drives = replace(DriveErrors.off(), stiffness_nm_rad=stiffness)
    controller, truth = make_cell(_exact(drives=drives))
    controller.change_tool("laser")
    controller.move_joints(Q_OUT)
    kin = truth.kinematics()
    commanded = kin.fk(controller.read_joints())[:3, 3]
    real = kin.fk(truth.q())[:3, 3]
    return float(np.linalg.norm(real - commanded))


def test_compliant_joints_sag_by_torque_over_stiffness() -> None:
    """0.05-0.4 mm at the default stiffness; twice as stiff, half the sag (within 2 %)."""
    soft = _sag_m((1.5e6, 1.0e6))
    stiff = _sag_m((3.0e6, 2.0e6))
    assert 0.05e-3 < soft < 0.4e-3
    assert stiff / soft == pytest.approx(0.5, rel=0.02)


def test_lost_motion_depends_on_the_side_a_joint_came_from() -> None:
    """Joint 1 brought to the same command from below and from above stops h apart."""
    h = 4e-5
    drives = replace(DriveErrors.off(), hysteresis_rad=(h, 0.0, 0.0, 0.0, 0.0, 0.0))
    controller, truth = make_cell(_exact(drives=drives))
    target = controller.q_home.copy()
    stops = []
    for start in (-0.2, 0.2):
        controller.move_joints(target + np.array([start, 0, 0, 0, 0, 0]))
        controller.move_joints(target)
        stops.append(truth.q()[0])
    assert stops[1] - stops[0] == pytest.approx(h, abs=2e-7)  # the servo's own error: 0.2 urad
    np.testing.assert_allclose(controller.read_joints(), target, atol=1e-9)  # encoders see none


def test_a_pose_reached_again_lands_within_the_repeatability() -> None:
    sigma = 1e-5
    controller, truth = make_cell(_exact(drives=replace(DriveErrors.off(), repeat_sigma_rad=sigma)))
    target = controller.q_home + 0.1
    stops = []
    for _ in range(25):
        controller.move_joints(target - 0.05)  # always from the same side
        controller.move_joints(target)
        stops.append(truth.q() - target)
    spread = np.std(np.array(stops))  # 150 samples
    assert spread == pytest.approx(sigma, rel=0.2)


def test_thermal_drift_grows_with_time() -> None:
    drives = replace(DriveErrors.off(), drift_rad_per_s=(1e-6, -2e-6))
    controller, truth = make_cell(_exact(drives=drives))
    controller.move_joints(controller.q_home + 0.01)
    t0, q0 = controller.time_s, truth.q()
    controller.move_joints(controller.q_home)
    controller.move_joints(controller.q_home + 0.01)
    dt, dq = controller.time_s - t0, truth.q() - q0
    np.testing.assert_allclose(dq[1:3], -np.array([1e-6, -2e-6]) * dt, rtol=0.05, atol=2e-8)


@pytest.mark.slow
def test_tools_seat_within_the_changers_repeatability() -> None:
    sigma_m = 5e-6
    tools = replace(ToolErrors.off(), changer_sigma_m=sigma_m)
    controller, truth = make_cell(_exact(tools=tools))
    seats = []
    for _ in range(12):
        controller.change_tool("ir")
        seats.append(truth.T_flange_tool("ir")[:3, 3])
        controller.return_tool()
    spread = np.std(np.array(seats), axis=0)  # 12 locks per axis
    assert np.all((spread > 0.4 * sigma_m) & (spread < 2.0 * sigma_m))


def test_the_tools_real_tcps_and_the_lasers_mounting_are_off_their_nominal() -> None:
    tools = replace(ToolErrors.off(), tcp_sigma_m=1e-4, laser_mount_sigma_m=2e-4)
    controller, truth = make_cell(_exact(tools=tools))
    offsets = {}
    for tool in ("screwer", "laser"):
        controller.change_tool(tool)
        sim = truth.simulation
        T_base_tool = sim.body_T(sim.tool_body[tool])
        T_tool_tcp = np.linalg.inv(T_base_tool) @ truth.T_base_tcp(tool)
        _, offsets[tool] = pose_error(T_tool_tcp, controller.T_flange_tcp(tool))
    # Three Gaussian axes: the offset is sigma * chi(3), within (0.1, 4) sigma at 99.9 %.
    assert 1e-5 < offsets["screwer"] < 4e-4 and 2e-5 < offsets["laser"] < 8e-4


def test_the_laser_range_has_a_scale_error() -> None:
    """Ground truth: the table top's height under the laser, straight down."""
    controller, truth = make_cell(_exact(tools=replace(ToolErrors.off(), laser_scale_sigma=1e-3)))
    controller.change_tool("laser")
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = [TABLE_TOP_POS[0], 0.1, TABLE_TOP_POS[2] + 0.3]
    controller.move_tcp(T)
    reading = controller.read_laser()
    centre = len(reading.distances) // 2
    height = truth.T_base_tcp("laser")[2, 3] - truth.T_base_table()[2, 3]
    scale = reading.distances[centre] / height - 1.0
    assert scale == pytest.approx(truth.params.laser_scale, abs=1e-6)
    assert abs(scale) > 1e-6


def test_the_table_travels_with_its_guideways_bow_pitch_and_yaw() -> None:
    table = TableErrors(0.0, 0.0, 2e-5, 2.5e-5, 2.5e-5)
    controller, truth = make_cell(_exact(table=table))
    for s in (-0.4, 0.0, 0.45):
        controller.move_table(s)
        T = truth.T_base_table()
        ex, ez, pitch, yaw = table_profile(truth.params.table_profile, s, TABLE_TRAVEL)
        np.testing.assert_allclose(T[0, 3] - TABLE_TOP_POS[0], ex, atol=2e-7)
        np.testing.assert_allclose(T[2, 3] - TABLE_TOP_POS[2], ez, atol=2e-7)
        np.testing.assert_allclose(T[2, 1], np.sin(pitch), atol=2e-7)  # y axis tilted up
        np.testing.assert_allclose(T[1, 0], np.sin(yaw), atol=2e-7)  # x axis turned
