"""The controller API: the real/nominal boundary, each error source and its zero setting,
sensors against known geometry, and bad input refused with clear messages."""

from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime

import mujoco
import numpy as np
import pytest

from cell import (
    CellConfigError,
    Controller,
    FixedMesh,
    JointLimitError,
    LaserConfig,
    ToolChangerError,
    UnknownNameError,
    UnreachableTargetError,
    nominal_kinematics,
)
from cell.sim import CellConfig, CellTruth, DriveErrors, EncoderNoise, TableErrors, make_cell
from cell.sim.real import RealParameters, draw_real_parameters
from cell.sim.simulation import Simulation
from registration.rigid import make_T

R_DOWN = np.diag([1.0, -1.0, -1.0])


@pytest.fixture(scope="module")
def laser_cell() -> tuple[Controller, CellTruth]:
    """Default errors, laser in hand, above the bare table."""
    controller, truth = make_cell(CellConfig(seed=4))
    controller.change_tool("laser")
    return controller, truth


def test_controller_exposes_no_truth() -> None:
    controller, _ = make_cell(CellConfig(seed=1))
    hidden = (Simulation, CellTruth, RealParameters, LaserConfig, mujoco.MjModel, mujoco.MjData)
    public = [name for name in dir(controller) if not name.startswith("_")]
    for name in public:
        value = getattr(controller, name)
        assert not isinstance(value, hidden), name
    # The arm it moves with is set through its absolute-accuracy option, not by assignment.
    with pytest.raises(AttributeError):
        controller.kinematics = controller.nominal_kinematics  # type: ignore[misc]


def test_real_arm_deviates_by_an_industrial_arms_accuracy() -> None:
    kin = nominal_kinematics()
    params = draw_real_parameters(CellConfig(seed=0))
    config = CellConfig(seed=0)
    m = mujoco.MjModel.from_xml_string(config.robot.mjcf(params.deviations))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    errors = []
    for _ in range(200):
        q = kin.random_configuration(rng)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        errors.append(np.linalg.norm(d.site_xpos[m.site("flange").id] - kin.fk(q)[:3, 3]))
    assert 0.1e-3 < np.mean(errors) < 0.6e-3  # IRB 2400: mean 0.18 mm, max 0.38 mm per unit
    assert np.max(errors) < 1.5e-3


def test_ideal_config_zeroes_every_error() -> None:
    controller, truth = make_cell(CellConfig(seed=3).ideal())
    assert not truth.deviations.any()
    controller.move_table(0.3)
    assert controller.table_position() == truth.table_position_m()
    np.testing.assert_array_equal(controller.read_joints(), truth.q())


def test_encoder_noise_has_the_configured_sigma() -> None:
    config = CellConfig(seed=2, encoder=EncoderNoise(1e-4), drives=DriveErrors.off())
    controller, truth = make_cell(config)
    noise = np.array([controller.read_joints() - truth.q() for _ in range(500)])
    assert abs(noise.std() / 1e-4 - 1.0) < 0.1  # 3000 samples: sigma within 10 %
    assert abs(noise.mean()) < 1.5e-5


def test_another_noise_draw_is_the_same_cell_with_other_noise() -> None:
    """`noise_draw` 0 is the seed's own draw (the readings of a cell built without it, to the
    bit); another draw keeps every drawn error of the cell (its truth's parameters, to the
    bit) and draws the encoders' noise anew: independent, with the same sigma (3000 samples:
    within 10 %; the correlation of two draws' noise below 0.1)."""
    noises = {}
    for draw in (None, 0, 1):
        config = CellConfig(seed=2, encoder=EncoderNoise(1e-4), drives=DriveErrors.off())
        if draw is not None:
            config = replace(config, noise_draw=draw)
        controller, truth = make_cell(config)
        noises[draw] = np.array([controller.read_joints() - truth.q() for _ in range(500)])
        if draw == 1:
            _same_parameters(truth.params, draw_real_parameters(replace(config, noise_draw=0)))
    np.testing.assert_array_equal(noises[0], noises[None])
    assert abs(noises[1].std() / 1e-4 - 1.0) < 0.1
    correlation = np.corrcoef(noises[0].ravel(), noises[1].ravel())[0, 1]
    assert abs(correlation) < 0.1, correlation


def test_a_warm_arm_stands_off_a_cold_one_by_its_zero_shift() -> None:
    """Three cells alike but for how long the arm has run when their clocks start: cold, one
    time constant and ten: at the same encoder readings (the motors at home, no noise) the
    links stand off the cold arm's by `warmup_rad` (motor less link) times 1 - exp(-t/tau),
    to 2e-7 rad (each arm's servo stands within 1e-7 rad of its set-point at rest), a
    thousandth of the shift."""
    shift = np.array([0.0, 2e-4, -1.5e-4, 0.0, 1e-4, 0.0])
    motors, links = {}, {}
    for warm_s in (0.0, 600.0, 6000.0):
        drives = replace(DriveErrors.off(), warmup_rad=tuple(shift), warmup_tau_s=600.0,
                         warm_s=warm_s)  # fmt: skip
        controller, truth = make_cell(replace(CellConfig(seed=2).ideal(), drives=drives))
        motors[warm_s], links[warm_s] = controller.read_joints(), truth.q()
    np.testing.assert_allclose(motors[0.0], motors[6000.0], atol=1e-7)
    np.testing.assert_allclose(motors[0.0], motors[600.0], atol=1e-7)
    settled = 0.2  # the cell settles that long when it is built: its clock's start
    for warm_s in (600.0, 6000.0):
        grown = np.exp(-settled / 600.0) - np.exp(-(warm_s + settled) / 600.0)
        np.testing.assert_allclose(links[0.0] - links[warm_s], shift * grown, atol=2e-7)


def _same_parameters(a: RealParameters, b: RealParameters) -> None:
    for name in ("deviations", "table_bias_m", "stiffness_nm_rad", "laser_scale", "table_profile"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.T_tool_tcp.keys() == b.T_tool_tcp.keys()
    for tool, T in a.T_tool_tcp.items():
        np.testing.assert_array_equal(T, b.T_tool_tcp[tool], err_msg=tool)


def test_the_controller_s_clock_is_the_cell_s_where_it_keeps_one() -> None:
    """A cell started at a given date and time: its controller's clock is that plus the
    simulated time, as the arm moves (1 us); a cell without one reads this computer's clock
    (within the seconds the test takes); a start without a time zone is refused."""
    start = datetime(2026, 1, 5, 8, 0, tzinfo=UTC)
    controller, _ = make_cell(CellConfig(seed=2, clock_start_utc=start))
    controller.move_table(0.3)
    assert controller.time_s > 0.5
    ahead = (controller.clock_utc() - start).total_seconds()
    assert ahead == pytest.approx(controller.time_s, abs=1e-6)
    own, _ = make_cell(CellConfig(seed=2))
    assert abs((own.clock_utc() - datetime.now(UTC)).total_seconds()) < 60.0
    with pytest.raises(CellConfigError, match="no time zone"):
        CellConfig(clock_start_utc=datetime(2026, 1, 5, 8, 0))


def test_table_error_is_hidden_from_the_readout() -> None:
    config = CellConfig(seed=7, table=TableErrors(bias_sigma_m=1e-3, repeat_sigma_m=0.0))
    controller, truth = make_cell(config)
    controller.move_table(0.2)
    assert abs(controller.table_position() - 0.2) < 1e-6  # the axis believes it is there
    bias = truth.params.table_bias_m
    assert abs(bias) > 1e-5
    assert abs(truth.table_position_m() - (0.2 + bias)) < 1e-6  # it is off by the bias


def test_laser_noise_and_plane(laser_cell) -> None:
    controller, truth = laser_cell
    controller.move_tcp(make_T(R_DOWN, np.array([1.0, -0.2, 0.7])))
    z = []
    for _ in range(5):
        points, index = controller.laser_points_base(controller.read_laser())
        assert len(index) == len(controller.laser_directions_tcp)  # all rays hit the table top
        z.append(points[:, 2])
    z = np.concatenate(z) - truth.T_base_table()[2, 3]
    # Range noise 20 um plus the arm's 0.3 mm kinematic error (a bias and a tilt).
    assert np.abs(z).max() < 2e-3
    residual = z - np.mean(z)
    assert residual.std() > 1e-5  # noisy, not exact


def test_laser_drops_grazing_rays(laser_cell) -> None:
    controller, truth = laser_cell
    tilt = 1.15  # rad from the vertical about the tool's y axis: incidences 0.85 .. 1.45 rad
    c, s = np.cos(tilt), np.sin(tilt)
    R = R_DOWN @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    controller.move_tcp(make_T(R, np.array([0.95, -0.2, 0.5])))
    reading = controller.read_laser()
    T_base_laser = controller.T_base_tcp()
    directions = controller.laser_directions_tcp @ T_base_laser[:3, :3].T
    incidence = np.arccos(np.clip(-directions[:, 2], -1, 1))  # table normal is +z
    max_incidence = controller.laser_max_incidence_rad
    height = T_base_laser[2, 3] - truth.T_base_table()[2, 3]
    in_range = height / np.cos(np.minimum(incidence, 1.5)) < controller.laser_range_m[1]
    steep = (incidence < max_incidence - 0.01) & in_range
    grazing = incidence > max_incidence + 0.01
    assert steep.any() and grazing.any()
    assert np.all(np.isfinite(reading.distances[steep]))
    assert np.all(np.isnan(reading.distances[grazing]))


def test_laser_ray_into_the_void_is_no_return(laser_cell) -> None:
    controller, _ = laser_cell
    up = np.diag([1.0, 1.0, 1.0])  # pointing at the sky
    controller.move_tcp(make_T(up, np.array([0.6, 0.0, 1.5])))
    reading = controller.read_laser()
    assert np.all(np.isnan(reading.distances))
    points, index = controller.laser_points_base(reading)
    assert points.shape == (0, 3) and index.shape == (0,)


def test_ir_reads_the_distance_to_the_table() -> None:
    controller, _ = make_cell(CellConfig(seed=5).ideal())
    controller.change_tool("ir")
    controller.move_tcp(make_T(R_DOWN, np.array([1.1, 0.1, 0.5])))
    assert abs(controller.read_ir() - 0.1) < 1e-9  # 0.5 m above a table top at 0.4 m
    controller.move_tcp(make_T(R_DOWN, np.array([1.1, 0.1, 0.7])))
    assert controller.read_ir() is None  # 0.3 m: beyond its 0.15 m range


def test_bad_commands_are_refused_with_clear_messages(laser_cell) -> None:
    controller, _ = laser_cell
    far = make_T(R_DOWN, np.array([2.5, 0.0, 0.5]))
    with pytest.raises(UnreachableTargetError, match=r"2\.5000.*residual"):
        controller.move_tcp(far)
    with pytest.raises(UnreachableTargetError, match="residual"):
        controller.move_linear(far)
    with pytest.raises(JointLimitError, match=r"joint2 = 2"):
        controller.move_joints(np.array([0.0, 2.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(JointLimitError, match="travel"):
        controller.move_table(0.8)
    with pytest.raises(ToolChangerError, match="already holds the 'laser' tool"):
        controller.lock()
    with pytest.raises(ToolChangerError, match="would fall"):
        controller.unlock()
    with pytest.raises(UnknownNameError, match="available tools: gripper, screwer, ir, laser"):
        controller.change_tool("welder")
    with pytest.raises(ToolChangerError, match="'ir' tool is not in hand"):
        controller.read_ir()
    assert controller.tool_in_hand == "laser"


def test_lock_without_a_tool_at_the_flange_is_refused() -> None:
    controller, _ = make_cell(CellConfig(seed=6))
    with pytest.raises(ToolChangerError, match="no tool is seated"):
        controller.lock()
    with pytest.raises(ToolChangerError, match="holds no tool"):
        controller.unlock()


def test_bad_config_is_refused() -> None:
    with pytest.raises(CellConfigError, match="n_rays"):
        LaserConfig(n_rays=0)
    with pytest.raises(CellConfigError, match="range_min_m < range_max_m"):
        LaserConfig(range_min_m=0.5, range_max_m=0.1)
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    with pytest.raises(CellConfigError, match="face indices"):
        FixedMesh("m", v, np.array([[0, 1, 7]]), np.eye(4))
    with pytest.raises(CellConfigError, match="rigid"):
        FixedMesh("m", v, np.array([[0, 1, 2]]), 2 * np.eye(4))
    with pytest.raises(CellConfigError, match="unique"):
        CellConfig(fixtures=(FixedMesh("m", v, np.array([[0, 1, 2]]), np.eye(4)),) * 2)


def test_truth_kinematics_is_the_real_arm() -> None:
    controller, truth = make_cell(CellConfig(seed=8))
    controller.move_joints(np.array([0.3, 0.2, -0.1, 0.5, 1.0, -0.3]))
    sim = truth.simulation
    mujoco.mj_forward(sim.model, sim.data)
    T_real = truth.kinematics().fk(truth.q())
    np.testing.assert_allclose(T_real, sim.site_T(sim.flange_site), atol=1e-12)
    T_nominal = controller.kinematics.fk(truth.q())
    assert np.linalg.norm(T_real[:3, 3] - T_nominal[:3, 3]) > 1e-5  # the two differ


def test_points_in_table_frame_with_the_nominal_table_pose() -> None:
    from cell import nominal_T_base_table, points_in_table_frame

    T = nominal_T_base_table(0.25)
    p_table = np.array([[0.1, -0.2, 0.05], [0.0, 0.0, 0.0]])
    p_base = p_table @ T[:3, :3].T + T[:3, 3]
    np.testing.assert_allclose(p_base[1], [1.15, 0.25, 0.4])  # table frame origin
    np.testing.assert_allclose(points_in_table_frame(p_base, T), p_table, atol=1e-15)


def test_mesh_with_convex_pieces_collides_by_its_pieces_and_is_seen_exactly() -> None:
    v = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (0.0, 0.1)])
    faces = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    lower, upper = v * [1, 1, 0.5], v * [1, 1, 0.5] + [0, 0, 0.05]  # two boxes, 5 cm each
    obj = FixedMesh("crate", v, faces, np.eye(4), convex_pieces=(lower, upper))
    controller, truth = make_cell(CellConfig(seed=9, fixtures=(obj,)).ideal())
    m = truth.simulation.model
    exact = m.geom("crate")
    assert exact.contype[0] == 0 and exact.conaffinity[0] == 0 and exact.group[0] == 1
    hull = m.geom("crate_hull1")
    assert hull.contype[0] == 1 and hull.group[0] == 5
    controller.change_tool("ir")
    controller.move_tcp(make_T(R_DOWN, np.array([1.15, 0.0, 0.6])))
    assert abs(controller.read_ir() - 0.1) < 1e-6  # top face at 0.4 + 0.1 m, IR 0.6 m up
    flat = FixedMesh("flat", v, faces, np.eye(4), convex_pieces=(v[:4],))  # coplanar piece
    with pytest.raises(CellConfigError, match="flat_hull0"):
        make_cell(CellConfig(fixtures=(flat,)))
    flat = FixedMesh("flat", v, faces, np.eye(4), convex_pieces=(v[:4],))  # coplanar piece
    with pytest.raises(CellConfigError, match="flat_hull0"):
        make_cell(CellConfig(fixtures=(flat,)))
