"""Mechanical parts: exact solids of the designed volume, operation frames where the holes are."""

from __future__ import annotations

import igl
import numpy as np
import pytest
import trimesh

from models.model_errors import MeshDataError, UnknownModelError
from models.registry import builtin_model, builtin_names
from models.targets import OperationFrame

# Volumes from the drawings [mm^3]; holes are 48-gon prisms: area (48/2) r^2 sin(2 pi/48).
_POLYGON = 24 * np.sin(2 * np.pi / 48)


def _hole(r: float, depth: float) -> float:
    return _POLYGON * r**2 * depth


def _boss(r: float, height: float) -> float:
    return _POLYGON * r**2 * height


def _housing_volume() -> float:
    outer, inner = 100 * 70 * 40, (100 - 8) * (70 - 8) * (40 - 4)
    # bosses: 10 mm cylinders at the corners, partly inside the walls; computed by the
    # area of the 48-gon disc that lies inside the cavity (sampled densely).
    xs = np.linspace(-5, 5, 2001)
    gx, gy = np.meshgrid(xs, xs)
    angle = np.arctan2(gy, gx)
    sector = 2 * np.pi / 48
    apothem = 5 * np.cos(sector / 2)
    phi = np.mod(angle, sector) - sector / 2
    inside_disc = np.hypot(gx, gy) * np.cos(phi) <= apothem
    # corner boss centre (41, 26); cavity is |x| < 46, |y| < 31
    in_cavity = (41 + gx < 46) & (26 + gy < 31)
    cell = (xs[1] - xs[0]) ** 2
    boss_in_cavity = np.sum(inside_disc & in_cavity) * cell * 36  # height above the floor
    return outer - inner + 4 * boss_in_cavity - 4 * _hole(2.1, 12)


EXPECTED_VOLUME_MM3 = {
    "bracket": 80 * 50 * 6 + 80 * 6 * 50 - 4 * _hole(3.3, 6),
    "lid": 100 * 70 * 4 + 20 * 20 * 10 - 4 * _hole(2.75, 4),
    "housing": _housing_volume(),
}


def _signed_distance(points: np.ndarray, mesh) -> np.ndarray:
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    tree = igl.AABB()
    tree.init(vertices, faces)
    distance = np.sqrt(tree.squared_distance(vertices, faces, np.asarray(points, float))[0])
    inside = igl.fast_winding_number(vertices, faces, np.asarray(points, float)) > 0.5
    return np.where(inside, -distance, distance)


@pytest.mark.parametrize("name", ["bracket", "housing", "lid"])
def test_part_is_a_closed_solid_of_the_designed_volume(name) -> None:
    part = builtin_model(name)
    tm = part.mesh.to_trimesh()
    assert tm.is_watertight and tm.volume > 0
    assert len(trimesh.graph.connected_components(tm.face_adjacency, engine="scipy")) == 1
    assert tm.volume * 1e9 == pytest.approx(EXPECTED_VOLUME_MM3[name], rel=2e-3)
    # refined for scans and model error: edges about 3 mm, none long
    assert np.median(tm.edges_unique_length) <= 3.0e-3
    assert tm.edges_unique_length.max() <= 8e-3


@pytest.mark.parametrize("name", ["bracket", "housing", "lid"])
def test_part_frames_are_named_rigid_and_of_known_kinds(name) -> None:
    part = builtin_model(name)
    names = [f.name for f in part.frames]
    assert len(set(names)) == len(names)
    kinds = {f.kind for f in part.frames}
    assert "grasp" in kinds and "insert" in kinds
    for frame in part.frames:
        R = frame.T_part_frame[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
    with pytest.raises(UnknownModelError, match="grasp"):
        part.frame("no_such_frame")


@pytest.mark.parametrize("name", ["bracket", "housing", "lid"])
def test_screw_frames_sit_on_the_holes(name) -> None:
    part = builtin_model(name)
    screws = [f for f in part.frames if f.kind == "screw"]
    assert len(screws) >= 2
    for frame in screws:
        T = frame.T_part_frame
        origin, z, x = T[:3, 3], T[:3, 2], T[:3, 0]
        probes = np.array(
            [
                origin + 2e-3 * z,  # down the hole: no material
                origin + 2e-3 * z + 4.5e-3 * x,  # beside the hole: material
                origin - 2e-3 * z,  # above the entry: outside
            ]
        )
        sd = _signed_distance(probes, part.mesh)
        assert sd[0] > 0.5e-3, frame.name
        assert sd[1] < 0, frame.name
        assert sd[2] > 0, frame.name


def test_lid_screw_holes_line_up_with_the_housing_when_inserted() -> None:
    housing, lid = builtin_model("housing"), builtin_model("lid")
    T_housing_lid = housing.frame("lid_seat").T_part_frame @ np.linalg.inv(
        lid.frame("insert").T_part_frame
    )
    for i in range(1, 5):
        T_lid = T_housing_lid @ lid.frame(f"screw_{i}").T_part_frame
        # the lid's screw entry is 4 mm (its thickness) above the housing's thread entry
        p_housing = housing.frame(f"screw_{i}").T_part_frame[:3, 3]
        np.testing.assert_allclose(T_lid[:3, 3] - p_housing, [0, 0, 4e-3], atol=1e-9)
        np.testing.assert_allclose(T_lid[:3, 2], [0, 0, -1], atol=1e-12)
    # seated, the lid's plate lies on the housing's rim and does not overlap its walls
    lid_bottom = (T_housing_lid @ np.array([0.045, 0.0, 0.0005, 1.0]))[:3]
    assert _signed_distance(lid_bottom[None], housing.mesh)[0] > 0


@pytest.mark.parametrize("name", ["bracket", "housing", "lid"])
def test_part_convex_pieces_are_its_primitives(name) -> None:
    part = builtin_model(name)
    assert len(part.convex_pieces) == {"bracket": 2, "housing": 9, "lid": 2}[name]
    lo, hi = part.mesh.vertices.min(axis=0), part.mesh.vertices.max(axis=0)
    for piece in part.convex_pieces:
        tm = piece.to_trimesh()
        assert tm.is_watertight
        assert tm.volume == pytest.approx(tm.convex_hull.volume, rel=1e-9)
        assert (piece.vertices >= lo - 1e-9).all() and (piece.vertices <= hi + 1e-9).all()


def test_registry_lists_every_model_and_rejects_unknown_names() -> None:
    assert set(builtin_names()) == {"skull", "bracket", "housing", "lid", "ellipsoid"}
    with pytest.raises(UnknownModelError, match=r"skull.*bracket.*housing.*lid.*ellipsoid"):
        builtin_model("gearbox")
    with pytest.raises(LookupError):
        builtin_model("gearbox")


def test_operation_frame_rejects_non_rigid_transforms_and_unknown_kinds() -> None:
    with pytest.raises(MeshDataError, match="rigid"):
        OperationFrame("x", "grasp", np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(MeshDataError, match="kind"):
        OperationFrame("x", "weld", np.eye(4))


def test_ellipsoid_model_carries_the_papers_points_and_surface() -> None:
    model = builtin_model("ellipsoid")
    a, b, c = 0.10, 0.06, 0.04
    v = np.asarray(model.mesh.vertices)
    np.testing.assert_allclose(np.sum((v / [a, b, c]) ** 2, axis=1), 1.0, atol=1e-9)
    assert model.points is not None and model.points.shape == (55, 3)
    np.testing.assert_allclose(np.sum((model.points / [a, b, c]) ** 2, axis=1), 1.0, atol=1e-9)
    surface = model.surface
    assert surface is not None
    u = np.linspace(*surface.u_range, 7)
    w = np.linspace(*surface.v_range, 5)
    p = surface(*np.meshgrid(u, w))
    assert p.shape == (5, 7, 3)
    np.testing.assert_allclose(np.sum((p / [a, b, c]) ** 2, axis=-1), 1.0, atol=1e-12)
    tm = model.mesh.to_trimesh()
    assert tm.is_watertight
    assert tm.volume == pytest.approx(4 / 3 * np.pi * a * b * c, rel=2e-3)
    assert len(model.convex_pieces) == 1
