"""A mesh part lying loose on the table (`LooseMesh`): its mass from the volume, its rest,
the table carrying it, the rays seeing it, and the gripper lifting it; all measured in the
simulation against analytic values."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from cell import CellConfigError, LooseMesh
from cell.mass import mesh_mass_properties
from cell.scene_builder import OBJECT_GROUP
from cell.sim import CellConfig, make_cell
from models.registry import builtin_model
from registration import MeshModel
from registration.rigid import invert, make_T, pose_error

MM = 1e-3
#: The bracket: base plate 80 x 50 x 6 mm, upright 80 x 6 x 56 mm sharing a 80 x 6 x 6 mm
#: corner, four holes of radius 3.3 mm (48-gon prisms) through 6 mm of material each.
_HOLE_AREA_MM2 = 0.5 * 48 * 3.3**2 * np.sin(2 * np.pi / 48)
BRACKET_VOLUME_M3 = (80 * 50 * 6 + 80 * 6 * 56 - 80 * 6 * 6 - 4 * 6 * _HOLE_AREA_MM2) * MM**3
ALUMINIUM = 2700.0
XY_TABLE = np.array([-0.1, 0.02])


def test_mass_properties_of_a_box_are_the_analytic_ones() -> None:
    a, b, c = 0.08, 0.05, 0.006
    box = trimesh.creation.box(extents=(a, b, c))
    box.apply_translation([0.01, -0.02, c / 2])
    props = mesh_mass_properties(box.vertices, box.faces, ALUMINIUM)
    m = ALUMINIUM * a * b * c
    assert props.volume_m3 == pytest.approx(a * b * c, rel=1e-12)
    assert props.mass_kg == pytest.approx(m, rel=1e-12)
    np.testing.assert_allclose(props.p_object_com, [0.01, -0.02, c / 2], atol=1e-15)
    I_box = m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(props.I_com, I_box, atol=1e-15)
    # A given mass scales the inertia with it.
    heavy = mesh_mass_properties(box.vertices, box.faces, ALUMINIUM, mass_kg=1.0)
    np.testing.assert_allclose(heavy.I_com, I_box / m, rtol=1e-9, atol=1e-15)
    # An open surface (one face missing) or an inside-out one has no positive volume.
    with pytest.raises(CellConfigError, match="volume"):
        mesh_mass_properties(box.vertices, box.faces[:, ::-1], ALUMINIUM)


def test_bad_loose_meshes_are_refused_by_name() -> None:
    box = trimesh.creation.box(extents=(0.05, 0.05, 0.05))
    v, f = box.vertices, box.faces
    for kwargs, word in (
        ({"density_kg_m3": 0.0}, "density_kg_m3"),
        ({"mass_kg": -0.1}, "mass_kg"),
        ({"friction": float("nan")}, "friction"),
        ({"convex_pieces": (np.zeros((3, 3)),)}, "convex piece 0"),
    ):
        with pytest.raises(CellConfigError, match=word):
            LooseMesh("cube", v, f, np.eye(4), **kwargs)
    with pytest.raises(CellConfigError, match=r"LooseMesh 'cube': face indices"):
        LooseMesh("cube", v, f + 100, np.eye(4))
    cube = LooseMesh("cube", v, f, np.eye(4))
    with pytest.raises(CellConfigError, match="fixtures must be FixedMesh or FixedPrimitive"):
        CellConfig(fixtures=(cube,))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unique"):
        CellConfig(parts=(cube, cube))


def test_a_loose_part_starts_where_it_lies_on_the_table_and_takes_a_given_mass() -> None:
    """The table axis starts at its positioning error (seed 22: 0.19 mm); the part is placed
    relative to the table, not to where the table would be without the error."""
    part = replace(_bracket(0.0), mass_kg=0.5)
    controller, truth = make_cell(CellConfig(seed=22, parts=(part,)))
    assert abs(truth.table_error_m()) > 1.5e-4
    T = invert(truth.T_base_table()) @ truth.T_base_object("bracket")
    d_rot, d_pos = pose_error(T, part.T_table_object)
    assert d_pos < 3e-5 and np.degrees(d_rot) < 0.01  # contact softness: 15 um
    assert truth.simulation.model.body_mass[truth.simulation.model.body("bracket").id] == 0.5
    # The controller offers no way to the part's true pose.
    assert not [name for name in dir(controller) if "object" in name.lower()]


def _bracket(yaw_deg: float) -> LooseMesh:
    model = builtin_model("bracket")
    T = make_T(
        Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix(), np.append(XY_TABLE, 0.0)
    )
    return LooseMesh(
        "bracket",
        model.mesh.vertices,
        model.mesh.faces,
        T,
        convex_pieces=tuple(p.vertices for p in model.convex_pieces),
    )


@pytest.fixture(scope="module")
def bracket_cell():
    part = _bracket(15.0)
    controller, truth = make_cell(CellConfig(seed=21, parts=(part,)).ideal())
    return part, controller, truth


def test_loose_bracket_has_aluminium_mass_and_rests_still(bracket_cell) -> None:
    part, controller, truth = bracket_cell
    sim = truth.simulation
    body = sim.model.body("bracket").id
    # Mass: aluminium times the bracket's analytic volume (the mesh is exact: 0.01 %).
    assert sim.model.body_mass[body] == pytest.approx(ALUMINIUM * BRACKET_VOLUME_M3, rel=1e-4)
    # It rests where it was put: origin on the table top within 0.1 mm (contact softness),
    # the yaw kept within 0.01 deg.
    T0 = invert(truth.T_base_table()) @ truth.T_base_object("bracket")
    d_rot, d_pos = pose_error(T0, part.T_table_object)
    assert d_pos < 1e-4 and np.degrees(d_rot) < 0.01
    # Still for 3 s of simulated time: no sample more than 0.05 mm from the first.
    samples = []
    for _ in range(30):
        sim.settle(0.1)
        samples.append((invert(truth.T_base_table()) @ truth.T_base_object("bracket"))[:3, 3])
    assert np.max(np.linalg.norm(np.array(samples) - samples[0], axis=1)) < 5e-5
    # The table carries it by friction: 0.4 m out at full speed and back, it stays put on
    # the table within 0.05 mm and 0.01 deg.
    controller.move_table(0.4)
    controller.move_table(0.0)
    T1 = invert(truth.T_base_table()) @ truth.T_base_object("bracket")
    d_rot, d_pos = pose_error(T1, T0)
    assert d_pos < 5e-5 and np.degrees(d_rot) < 0.01
    assert sim.warnings() == 0


def test_rays_see_the_loose_bracket_exactly(bracket_cell) -> None:
    _, controller, truth = bracket_cell
    sim = truth.simulation
    # The exact mesh is in the group the rays see; its contact pieces are not.
    geoms = [g for g in range(sim.model.ngeom) if sim.model.geom_bodyid[g] == sim.model.body(
        "bracket").id]  # fmt: skip
    assert sorted(sim.model.geom_group[geoms]) == [OBJECT_GROUP, 5, 5]
    T_base_part = truth.T_base_object("bracket")
    # The IR sensor straight down over the base plate reads its top face (6 mm high).
    controller.change_tool("ir")
    p_plate = T_base_part[:3, :3] @ np.array([0.0, 15 * MM, 0.0]) + T_base_part[:3, 3]
    standoff = 0.05
    controller.move_tcp(
        make_T(np.diag([1.0, -1.0, -1.0]), p_plate + np.array([0, 0, 6 * MM + standoff]))
    )
    reading = controller.read_ir()
    assert reading is not None and abs(reading - standoff) < 2e-4  # arm settles to 0.2 mm
    # A laser line across the part: every return lies on the part's surface or the table.
    controller.change_tool("laser")
    centre = T_base_part[:3, 3] + np.array([0.0, 0.0, 0.25])
    controller.move_tcp(make_T(np.diag([1.0, -1.0, -1.0]), centre))
    points, _ = controller.laser_points_base(controller.read_laser())
    model = builtin_model("bracket")
    on_part = points[:, 2] > T_base_part[2, 3] + 1 * MM
    assert on_part.sum() > 30
    p_object = (points[on_part] - T_base_part[:3, 3]) @ T_base_part[:3, :3]
    # Exact point-triangle distances (libigl's AABB tree, independent of MuJoCo's ray cast).
    distance = MeshModel(model.mesh.vertices, model.mesh.faces).closest(p_object).distances
    assert np.max(distance) < 2e-4  # the ideal arm's settling, no laser noise


def test_gripper_lifts_the_loose_bracket_and_puts_it_back() -> None:
    part = _bracket(-10.0)
    controller, truth = make_cell(CellConfig(seed=22, parts=(part,)).ideal())
    sim = truth.simulation
    T_rest = truth.T_base_object("bracket")
    # The upright's top edge, fingers closing across its 6 mm thickness (tool x = part y).
    T_grasp = np.array(builtin_model("bracket").frame("grasp").T_part_frame)
    T_grasp[:3, :3] = T_grasp[:3, :3] @ np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    T_touch = T_rest @ T_grasp
    above = T_touch.copy()
    above[2, 3] += 0.08
    controller.change_tool("gripper")
    controller.set_gripper(0.03)
    controller.move_tcp(above)
    controller.move_linear(T_touch, speed_m_s=0.05)
    controller.set_gripper(0.0)
    # The fingers stop on the 6 mm upright (inner faces 1 mm + opening from the centre).
    np.testing.assert_allclose(sim.data.qpos[sim.finger_qadr], 2 * MM, atol=0.3 * MM)
    lift = T_touch.copy()
    lift[2, 3] += 0.04
    controller.move_linear(lift, speed_m_s=0.05, settle_s=1.0)
    T_up = truth.T_base_object("bracket")
    # Measured on the part: it rose by the lift within 0.5 mm, not a contact with the table.
    assert T_up[2, 3] - T_rest[2, 3] == pytest.approx(0.04, abs=5e-4)
    bodies = sim.model.geom_bodyid
    touching = {
        frozenset((int(bodies[g1]), int(bodies[g2])))
        for g1, g2 in zip(sim.data.contact.geom1, sim.data.contact.geom2, strict=True)
    }
    assert frozenset((sim.model.body("bracket").id, sim.model.body("table").id)) not in touching
    controller.move_linear(T_touch, speed_m_s=0.05)
    controller.set_gripper(0.03)
    controller.move_linear(above, speed_m_s=0.1)
    d_rot, d_pos = pose_error(truth.T_base_object("bracket"), T_rest)
    assert d_pos < 5e-4 and np.degrees(d_rot) < 0.5  # put back within 0.5 mm / 0.5 deg
    assert sim.warnings() == 0
