"""End-to-end physics of the cell: tool changes, grasping, the table carrying objects, and a
laser pass over a mesh object giving points on its surface."""

from __future__ import annotations

import igl
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from cell import FixedMesh, FixedPrimitive, LoosePart
from cell.controller import RACK_APPROACH_M
from cell.sim import CellConfig, make_cell
from registration.rigid import invert, make_T, pose_error

R_DOWN = np.diag([1.0, -1.0, -1.0])


def test_every_tool_is_picked_carried_and_returned_in_the_real_cell() -> None:
    controller, truth = make_cell(CellConfig(seed=11))  # perturbed arm, noisy sensors
    sim = truth.simulation
    for tool in controller.tools:
        controller.change_tool(tool)
        assert controller.tool_in_hand == tool
        T_flange_tool = truth.T_flange_tool(tool)
        # Seated within the changer's capture range despite the arm's kinematic error.
        dr, dp = pose_error(T_flange_tool, np.eye(4))
        assert dp < 3e-3 and dr < 0.02
        for p in ((1.0, -0.2, 0.9), (1.2, 0.25, 0.75)):
            controller.move_tcp(make_T(R_DOWN, np.array(p)))
            # The tool (and its TCP) follows the flange rigidly: same relative pose.
            dr, dp = pose_error(truth.T_flange_tool(tool), T_flange_tool)
            assert dp < 1e-6 and dr < 1e-6
            # The TCP is where the nominal model says, up to the arm's absolute accuracy.
            T_pred = controller.T_base_tcp()
            _, dp = pose_error(T_pred, truth.T_base_tcp(tool))
            assert dp < 2e-3
        controller.return_tool()
        assert controller.tool_in_hand is None
        _, dp = pose_error(sim.site_T(sim.slot_site[tool]), sim.body_T(sim.tool_body[tool]))
        assert dp < 3e-3  # back in its slot, held by the rack weld
        assert sim.data.eq_active[sim.rack_eq[tool]] == 1
        assert sim.data.eq_active[sim.flange_eq[tool]] == 0
        # The empty flange leaves the seat straight up, RACK_APPROACH_M above it (the truth's
        # flange against the slot's pose), not down into the tool it left.
        T_base_flange = sim.site_T(sim.flange_site)
        lift = T_base_flange[2, 3] - controller.T_base_slot(tool)[2, 3]
        assert abs(lift - RACK_APPROACH_M) < 3e-3, (tool, lift)
    assert sim.warnings() == 0


def test_gripper_grasps_and_lifts_a_part() -> None:
    part = LoosePart("cube", half_size=(0.02, 0.02, 0.02), mass=0.1, xy_table=(-0.1, 0.0))
    controller, truth = make_cell(CellConfig(seed=12, parts=(part,)))
    sim = truth.simulation
    body = sim.model.body("cube").id
    p_part = sim.data.xpos[body].copy()
    assert abs(p_part[2] - 0.42) < 1e-3  # resting on the table top
    controller.change_tool("gripper")
    controller.set_gripper(0.035)
    above = make_T(R_DOWN, p_part + np.array([0.0, 0.0, 0.15]))
    controller.move_tcp(above)
    controller.move_linear(make_T(R_DOWN, p_part + np.array([0.0, 0.0, 0.01])), speed_m_s=0.1)
    controller.set_gripper(0.0)  # squeeze: fingers stop on the part, force-limited
    fingers = sim.data.qpos[sim.finger_qadr]
    np.testing.assert_allclose(fingers, 0.019, atol=1.5e-3)  # stopped by the 40 mm cube
    controller.move_linear(above, speed_m_s=0.1)
    lifted = sim.data.xpos[body] - p_part
    np.testing.assert_allclose(lifted, [0.0, 0.0, 0.14], atol=2e-3)  # TCP rose 0.14 m
    # And it stays with the gripper on a sideways move.
    controller.move_linear(above @ make_T(np.eye(3), np.array([0.1, 0.0, 0.0])), speed_m_s=0.1)
    tcp = truth.T_base_tcp("gripper")[:3, 3]
    assert np.linalg.norm(sim.data.xpos[body] - tcp) < 0.012
    assert sim.warnings() == 0


def test_table_carries_fixed_and_loose_objects() -> None:
    box = FixedPrimitive(
        "block", "box", (0.05, 0.04, 0.03), make_T(np.eye(3), np.array([0.1, 0, 0.03]))
    )
    part = LoosePart("puck", half_size=(0.03, 0.03, 0.01), mass=0.2, xy_table=(-0.2, 0.1))
    controller, truth = make_cell(CellConfig(seed=13, fixtures=(box,), parts=(part,)))
    sim = truth.simulation
    T_table_block = np.linalg.inv(truth.T_base_table()) @ truth.T_base_object("block")
    p_part0 = sim.data.xpos[sim.model.body("puck").id].copy()
    s0 = truth.table_position_m()
    controller.move_table(0.4)
    moved = truth.table_position_m() - s0
    assert abs(moved - 0.4) < 1e-3  # 0.1 mm class positioning error
    # The block rides on the table (whose guideway tilts and bows it by microns).
    after = np.linalg.inv(truth.T_base_table()) @ truth.T_base_object("block")
    np.testing.assert_allclose(after, T_table_block, atol=1e-9)
    p_part = sim.data.xpos[sim.model.body("puck").id]
    np.testing.assert_allclose(p_part - p_part0, [0, moved, 0], atol=1e-3)  # friction holds it
    assert sim.warnings() == 0


def _object_mesh() -> trimesh.Trimesh:
    """A non-convex test object: a block with a ball half sunk into its top."""
    box = trimesh.creation.box(extents=(0.16, 0.12, 0.06))
    box.apply_translation([0, 0, 0.03])
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    ball.apply_translation([0.03, 0.0, 0.06])
    return trimesh.util.concatenate([box, ball])


@pytest.mark.parametrize("ideal", [True, False], ids=["noise-free", "real"])
def test_laser_pass_over_a_mesh_object_gives_points_on_its_surface(ideal: bool) -> None:
    mesh = _object_mesh()
    R = Rotation.from_euler("z", 25, degrees=True).as_matrix()
    T_table_object = make_T(R, np.array([0.05, 0.02, 0.0]))
    obj = FixedMesh("object", mesh.vertices, mesh.faces, T_table_object)
    config = CellConfig(seed=14, fixtures=(obj,))
    controller, truth = make_cell(config.ideal() if ideal else config)
    controller.change_tool("laser")
    controller.move_table(0.1)
    T_base_object = truth.T_base_object("object")
    c = T_base_object[:3, 3]
    points = []
    for dy in np.linspace(-0.08, 0.08, 9):
        controller.move_linear(make_T(R_DOWN, c + np.array([0.0, dy, 0.3])), settle_s=0.2)
        p, _ = controller.laser_points_base(controller.read_laser())
        points.append(p)
    P = np.concatenate(points)
    # Points on the object (above the table top by more than 2 mm), in the object frame.
    z_top = truth.T_base_table()[2, 3]
    on_object = P[P[:, 2] > z_top + 2e-3]
    p_object = on_object @ invert(T_base_object)[:3, :3].T + invert(T_base_object)[:3, 3]
    sq, _, _ = igl.point_mesh_squared_distance(p_object, mesh.vertices, mesh.faces)
    distance = np.sqrt(sq)
    assert len(on_object) > 500
    if ideal:
        assert distance.max() < 1e-6
    else:
        # Arm accuracy (~0.3-0.9 mm), table error (0.1 mm), encoder and range noise.
        assert np.median(distance) < 1e-3 and distance.max() < 3e-3


def test_scanning_while_moving_gives_points_on_a_sphere() -> None:
    """Each line is stamped with the joints of its own instant: no motion blur in the points."""
    T_table_ball = make_T(np.eye(3), np.array([0.1, 0.05, 0.06]))
    ball = FixedPrimitive("ball", "sphere", (0.06,), T_table_ball)
    controller, truth = make_cell(CellConfig(seed=15, fixtures=(ball,)).ideal())
    controller.change_tool("laser")
    c = truth.T_base_object("ball")[:3, 3]
    controller.move_linear(make_T(R_DOWN, c + np.array([0.0, -0.08, 0.3])))
    readings = controller.scan_linear(
        make_T(R_DOWN, c + np.array([0.0, 0.08, 0.3])), speed_m_s=0.1, period_s=0.02
    )
    assert len(readings) > 50
    P = np.concatenate([controller.laser_points_base(r)[0] for r in readings])
    on_ball = P[P[:, 2] > truth.T_base_table()[2, 3] + 1e-3]
    assert len(on_ball) > 1000
    radial = np.abs(np.linalg.norm(on_ball - c, axis=1) - 0.06)
    assert radial.max() < 1e-6  # 0.1 m/s: 0.2 mm per physics step if the stamp lagged


def test_screwer_spindle_turns_at_the_commanded_speed() -> None:
    controller, truth = make_cell(CellConfig(seed=16).ideal())
    controller.change_tool("screwer")
    sim = truth.simulation
    qadr = sim.model.joint("screwer_spindle").qposadr[0]
    angle0 = sim.data.qpos[qadr]
    controller.spin_screwer(20.0, 1.0)
    turned = sim.data.qpos[qadr] - angle0
    assert abs(turned - 20.0) < 0.5  # 20 rad/s for 1 s, minus the spin-up
