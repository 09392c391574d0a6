"""The skull phantom: size, closed surface, anatomy, determinism, burr holes, contact pieces."""

from __future__ import annotations

import igl
import numpy as np
import pytest
import trimesh

from models.model_errors import ModelParameterError
from models.registry import builtin_model
from models.skull import make_skull


@pytest.fixture(scope="module")
def skull():
    return builtin_model("skull", seed=0)


def _signed_distance(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Exact distance to the mesh (libigl AABB), negative inside (generalised winding number)."""
    vertices, faces = np.asarray(vertices), np.asarray(faces)
    points = np.asarray(points, dtype=float)
    tree = igl.AABB()
    tree.init(vertices, faces)
    distance = np.sqrt(tree.squared_distance(vertices, faces, points)[0])
    inside = igl.fast_winding_number(vertices, faces, points) > 0.5
    return np.where(inside, -distance, distance)


def _first_hit_x(skull, y_mm: float, z_mm: float) -> float:
    """x [mm] where a ray coming from the front (x = +0.3 m, going -x) first meets the skull."""
    hits = igl.ray_mesh_intersect(
        np.array([0.3, y_mm * 1e-3, z_mm * 1e-3]),
        np.array([-1.0, 0.0, 0.0]),
        np.asarray(skull.mesh.vertices),
        np.asarray(skull.mesh.faces),
        True,
    )
    assert hits, f"the ray at y={y_mm} mm, z={z_mm} mm misses the skull"
    return (0.3 - hits[0][1]) * 1e3


def test_skull_is_one_closed_outward_surface_of_skull_size(skull) -> None:
    tm = skull.mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent
    assert len(trimesh.graph.connected_components(tm.face_adjacency, engine="scipy")) == 1
    assert tm.volume > 0  # outward normals
    length_mm, breadth_mm, height_mm = 1e3 * tm.extents
    assert 180.0 <= length_mm <= 200.0
    assert 120.0 <= breadth_mm <= 160.0 and 160.0 <= height_mm <= 200.0
    assert 50_000 <= len(tm.faces) <= 150_000
    assert tm.area_faces.min() > 0


def test_skull_has_orbits_nose_and_free_zygomatic_arches(skull) -> None:
    brow = _first_hit_x(skull, 30.0, 15.0)
    orbit = _first_hit_x(skull, 32.0, -8.0)
    nose = _first_hit_x(skull, 0.0, -40.0)
    cheek = _first_hit_x(skull, 46.0, -32.0)
    assert brow > 75.0  # brow ridge in front
    assert brow - orbit > 15.0  # the orbit is a deep cavity below it
    assert cheek - nose > 10.0  # the nasal aperture is recessed behind the cheekbones
    # Zygomatic arch: seen from the side, there is a gap (temporal fossa) between the arch
    # and the vault: a vertical line through it is outside the solid right inside the arch.
    sd = _signed_distance(
        np.array([[0.02, 0.068, -0.030], [0.02, 0.061, -0.030], [0.02, 0.0, -0.030]]),
        skull.mesh.vertices,
        skull.mesh.faces,
    )
    assert sd[0] < 0 and sd[1] > 0 and sd[2] < 0  # arch, gap, skull


def test_skull_is_mirror_symmetric_left_right(skull) -> None:
    mirrored = np.asarray(skull.mesh.vertices) * [1.0, -1.0, 1.0]
    sd = _signed_distance(mirrored, skull.mesh.vertices, skull.mesh.faces)
    # The shape is symmetric; the triangulation of each side is not exactly (marching-cubes
    # case choices, smoothing), which leaves chord-sized differences.
    assert np.sqrt(np.mean(sd**2)) < 0.05e-3
    assert np.abs(sd).max() < 0.5e-3


def test_skull_is_deterministic_in_its_seed() -> None:
    a = make_skull(5, spacing_mm=3.0)
    b = make_skull(5, spacing_mm=3.0)
    c = make_skull(6, spacing_mm=3.0)
    np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
    np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)
    assert a.shape != c.shape
    for phantom in (a, c):  # other seeds keep the anatomy's size and one closed surface
        tm = phantom.mesh.to_trimesh()
        assert tm.is_watertight and 0.18 <= tm.extents[0] <= 0.20
    assert a.mesh.vertices.shape != c.mesh.vertices.shape or not np.allclose(
        a.mesh.vertices, c.mesh.vertices
    )


@pytest.mark.parametrize("bad", [-1, 1.5, "3", True])
def test_skull_rejects_bad_seeds(bad) -> None:
    with pytest.raises(ModelParameterError, match="seed"):
        make_skull(bad)


def test_burr_holes_enter_the_vault_and_reach_deep_targets(skull) -> None:
    holes = skull.burr_holes
    assert len(holes) >= 3 and len({h.name for h in holes}) == len(holes)
    entries = np.array([h.p_entry for h in holes])
    targets = np.array([h.p_target for h in holes])
    sd_entry = _signed_distance(entries, skull.mesh.vertices, skull.mesh.faces)
    sd_target = _signed_distance(targets, skull.mesh.vertices, skull.mesh.faces)
    assert np.abs(sd_entry).max() < 1e-6  # on the surface
    assert (entries[:, 2] > 0.03).all()  # on the vault, above the orbits
    assert (sd_target < -0.02).all()  # deep inside
    for hole in holes:
        assert 0.04 <= hole.depth <= 0.06
        np.testing.assert_allclose(np.linalg.norm(hole.p_target - hole.p_entry), hole.depth)
        # 1 mm along the trajectory is inside, 1 mm against it outside
        sd = _signed_distance(
            np.array([hole.p_entry + 1e-3 * hole.direction, hole.p_entry - 1e-3 * hole.direction]),
            skull.mesh.vertices,
            skull.mesh.faces,
        )
        assert sd[0] < 0 < sd[1]
        T = hole.T_model_entry
        np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
        assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
        np.testing.assert_allclose(T[:3, 2], hole.direction)
        np.testing.assert_allclose(T[:3, 3], hole.p_entry)


def test_convex_pieces_are_convex_and_cover_the_skull(skull) -> None:
    pieces = skull.convex_pieces
    assert 2 <= len(pieces) <= 24
    vertices = np.asarray(skull.mesh.vertices)
    inside_some = np.full(len(vertices), np.inf)
    for piece in pieces:
        tm = piece.to_trimesh()
        assert tm.is_watertight and tm.volume > 0
        assert tm.volume == pytest.approx(tm.convex_hull.volume, rel=1e-9)  # convex
        assert len(tm.vertices) <= 256
        sd = _signed_distance(vertices, piece.vertices, piece.faces)
        inside_some = np.minimum(inside_some, sd)
    # Contact geometry: nearly every surface point is within 1 mm of some piece.
    assert np.mean(inside_some < 1e-3) > 0.999
    assert inside_some.max() < 3e-3
