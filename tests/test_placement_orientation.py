"""A part placed as it lies: the placement's up axis, roll and pitch beside its yaw, in the
documented order (R_table_object = Rz(yaw) Ry(pitch) Rx(roll) R_up, about the table's axes),
resting with its lowest vertex lift_m above the top; the defaults give today's poses bit for
bit, with no new random draw."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from models.mesh import TriangleMesh
from models.model import ObjectModel
from registration import transform_points
from scenarios.configuration.cell_sections import Placement
from scenarios.configuration.config_error import ConfigError
from scenarios.configuration.config_files import load_config
from scenarios.offline.mesh_targets import generate_targets
from scenarios.offline.nominal_placement import nominal_pose, upright_rotation
from scenarios.offline.settings import NominalPlacement
from scenarios.realcell.real_placement import draw_true_pose

#: Rotations and positions built from exact quarter turns agree to rounding [-, m].
TOL = 1e-12
#: The rod: 200 mm long along the model's y, 40 mm across, its origin off its centre [m].
LENGTH, RADIUS, OFFSET = 0.2, 0.02, np.array([0.01, 0.03, 0.005])


def _rot(axis: int, deg: float) -> np.ndarray:
    """The right-handed rotation by `deg` about the coordinate axis `axis`, by hand."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _rod_y_up() -> np.ndarray:
    """Vertices (N, 3) [m] of a cylinder whose axis is the model's y (a y-up mesh)."""
    rod = trimesh.creation.cylinder(radius=RADIUS, height=LENGTH, sections=64)
    rod.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    rod.apply_translation(OFFSET)
    return np.asarray(rod.vertices)


def _documented_pose(vertices: np.ndarray, R: np.ndarray, xy: tuple[float, float], lift: float):
    """T_table_object by the documentation: rotation R, origin over xy, lowest point lift."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [xy[0], xy[1], lift - np.min((vertices @ R.T)[:, 2])]
    return T


def test_a_y_up_rod_stands_with_its_long_axis_vertical_and_lift_above_the_top() -> None:
    v = _rod_y_up()
    placement = NominalPlacement(up_axis="+y", yaw_deg=35.0, xy_m=(0.05, -0.02), lift_m=0.004)
    T = nominal_pose(placement, v)
    p = transform_points(T, v)
    extent = p.max(axis=0) - p.min(axis=0)
    assert extent[2] == pytest.approx(LENGTH, abs=TOL)  # the long axis is vertical
    assert max(extent[:2]) <= 2 * RADIUS + TOL  # the footprint is the rod's cross-section
    assert p[:, 2].min() == pytest.approx(0.004, abs=TOL)
    np.testing.assert_allclose(T[:3, :3] @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], rtol=0, atol=TOL)
    expected = _documented_pose(v, _rot(2, 35.0) @ _rot(0, 90.0), (0.05, -0.02), 0.004)
    np.testing.assert_allclose(T, expected, rtol=0, atol=TOL)
    # As modelled (the default +z), the rod lies on its side: 40 mm high.
    flat = transform_points(nominal_pose(NominalPlacement(yaw_deg=35.0), v), v)
    assert np.ptp(flat[:, 2]) == pytest.approx(2 * RADIUS, abs=1e-3)


@pytest.mark.parametrize("axis", ["+x", "-x", "+y", "-y", "+z", "-z"])
def test_each_up_axis_points_up_and_is_a_proper_rotation(axis: str) -> None:
    R = upright_rotation(NominalPlacement(up_axis=axis))
    e = np.zeros(3)
    e["xyz".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
    np.testing.assert_allclose(R @ e, [0.0, 0.0, 1.0], rtol=0, atol=TOL)
    np.testing.assert_allclose(R @ R.T, np.eye(3), rtol=0, atol=TOL)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=TOL)


def test_roll_then_pitch_then_yaw_turn_about_the_table_axes_in_that_order() -> None:
    # Roll 90 about x takes the model's y up; pitch 90 about y then takes it to the table's +x;
    # yaw 90 about the vertical then to +y.
    R = upright_rotation(NominalPlacement(roll_deg=90.0))
    np.testing.assert_allclose(R @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], rtol=0, atol=TOL)
    R = upright_rotation(NominalPlacement(roll_deg=90.0, pitch_deg=90.0))
    np.testing.assert_allclose(R @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], rtol=0, atol=TOL)
    v = _rod_y_up()
    placement = NominalPlacement(roll_deg=90.0, pitch_deg=90.0, yaw_deg=90.0)
    T = nominal_pose(placement, v)
    np.testing.assert_allclose(T[:3, :3] @ [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], rtol=0, atol=TOL)
    # Any angles, against the documented product built by hand.
    placement = NominalPlacement(up_axis="-x", roll_deg=12.0, pitch_deg=-33.0, yaw_deg=71.0)
    R = _rot(2, 71.0) @ _rot(1, -33.0) @ _rot(0, 12.0) @ _rot(1, 90.0)
    expected = _documented_pose(v, R, (0.0, 0.0), placement.lift_m)
    np.testing.assert_allclose(nominal_pose(placement, v), expected, rtol=0, atol=TOL)


def test_the_defaults_give_the_yaw_only_pose_bit_for_bit() -> None:
    v = _rod_y_up()
    for yaw, xy, lift in ((120.0, (0.0, 0.0), 0.004), (-47.3, (0.11, -0.07), 0.0123)):
        R = Rotation.from_euler("z", yaw, degrees=True).as_matrix()  # yaw only, as before
        expected = np.eye(4)
        expected[:3, :3] = R
        expected[:3, 3] = [xy[0], xy[1], -float(np.min(v @ R[2])) + lift]
        got = nominal_pose(NominalPlacement(yaw_deg=yaw, xy_m=xy, lift_m=lift), v)
        assert np.array_equal(got, expected)  # tolerance 0: the same bits


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_the_real_draw_at_the_defaults_is_the_yaw_and_tilt_draw_bit_for_bit(seed: int) -> None:
    v = _rod_y_up()
    placement = Placement()
    rng = np.random.default_rng(seed)
    got = draw_true_pose(placement, v, rng)
    # The draw by hand: 2 sideways, 1 yaw, 1 tilt, 1 heading; nothing more.
    hand = np.random.default_rng(seed)
    dxy = hand.uniform(-placement.range_xy_m, placement.range_xy_m, size=2)
    yaw = placement.yaw_deg + hand.uniform(-placement.range_yaw_deg, placement.range_yaw_deg)
    tilt = np.deg2rad(hand.uniform(-placement.range_tilt_deg, placement.range_tilt_deg))
    heading = hand.uniform(0.0, 2 * np.pi)
    R = (
        Rotation.from_rotvec(tilt * np.array([np.cos(heading), np.sin(heading), 0.0])).as_matrix()
        @ Rotation.from_euler("z", yaw, degrees=True).as_matrix()
    )
    expected = np.eye(4)
    expected[:3, :3] = R
    expected[:3, 3] = [*(np.array(placement.xy_m) + dxy), -float(np.min(v @ R[2])) + 0.004]
    assert np.array_equal(got, expected)
    assert rng.uniform() == hand.uniform()  # the stream is where it was: no extra draw


def test_the_real_draw_of_a_turned_part_stays_within_its_tilt_and_rests_on_the_table() -> None:
    v = _rod_y_up()
    placement = Placement(up_axis="+y", range_tilt_deg=5.0, range_yaw_deg=0.0, range_xy_m=0.0)
    for seed in range(20):
        T = draw_true_pose(placement, v, np.random.default_rng(seed))
        up = T[:3, :3] @ [0.0, 1.0, 0.0]  # the rod's axis
        assert np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0))) <= 5.0 + 1e-9
        assert transform_points(T, v)[:, 2].min() == pytest.approx(0.004, abs=TOL)
    still = Placement(up_axis="+y", range_tilt_deg=0.0, range_yaw_deg=0.0, range_xy_m=0.0)
    T = draw_true_pose(still, v, np.random.default_rng(3))
    np.testing.assert_allclose(T, nominal_pose(still, v), rtol=0, atol=TOL)


def test_targets_are_generated_on_the_upper_surface_as_the_part_lies() -> None:
    # A y-up block (its long side the model's y), its faces subdivided: a flat upper end.
    block = trimesh.creation.box(extents=(0.04, LENGTH, 0.06)).subdivide().subdivide()
    block.apply_translation(OFFSET)
    model = ObjectModel("block", TriangleMesh(block.vertices, block.faces), ())
    up = upright_rotation(NominalPlacement(up_axis="+y"))[2]  # the table's vertical, in the model
    holes = generate_targets(model, count=3, seed=0, up_model=up)
    top = OFFSET[1] + LENGTH / 2  # the block's upper end, in the model's y
    for hole in holes:
        assert hole.p_entry[1] == pytest.approx(top, abs=TOL)
        assert hole.direction @ [0.0, -1.0, 0.0] > 0.8  # into the part, downwards
        assert hole.depth == pytest.approx(LENGTH / 5, abs=TOL)


def test_a_job_carries_the_orientation_to_the_planner_and_refuses_a_bad_up_axis() -> None:
    config = load_config(
        "skull",
        overrides={
            "cell.object.placement.up_axis": "-x",
            "cell.object.placement.roll_deg": 10.0,
            "cell.object.placement.pitch_deg": -5.0,
        },
    )
    believed = config.planning().placement
    assert (believed.up_axis, believed.roll_deg, believed.pitch_deg) == ("-x", 10.0, -5.0)
    assert believed.yaw_deg == config.cell.object.placement.yaw_deg
    with pytest.raises(ConfigError) as error:
        load_config("skull", overrides={"cell.object.placement.up_axis": "y"})
    message = str(error.value)
    assert "\n" not in message
    assert "cell.object.placement.up_axis" in message
    assert "one of +x, -x, +y, -y, +z, -z (got 'y')" in message
