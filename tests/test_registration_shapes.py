"""The C operator: closest points on point sets, segments, meshes and parametric surfaces,
checked against brute force, dense sampling and analytic distances."""

from __future__ import annotations

import numpy as np
import pytest

from models import ellipsoid
from registration import InputError, MeshModel, ParametricModel, PointModel, SegmentModel
from registration.shapes.mesh_shape import sample_surface
from registration.synthetic import asymmetric_blob, icosphere


def test_point_model_matches_brute_force() -> None:
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 3))
    Q = rng.normal(size=(50, 3))
    c = PointModel(X).closest(Q)
    d_all = np.linalg.norm(Q[:, None] - X[None], axis=2)
    np.testing.assert_allclose(c.distances, d_all.min(axis=1), atol=1e-12)
    np.testing.assert_allclose(c.points, X[d_all.argmin(axis=1)], atol=1e-12)


def test_segment_distance_matches_the_analytic_formula() -> None:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    S = np.array([[0, 1], [1, 2]])
    model = SegmentModel(V, S)
    Q = np.array([[0.5, -0.3, 0.4], [-0.2, 0.0, 0.0], [1.3, 0.5, 0.0], [2.0, 2.0, 0.0]])
    expected = [np.hypot(0.3, 0.4), 0.2, 0.3, np.hypot(1.0, 1.0)]
    np.testing.assert_allclose(model.closest(Q).distances, expected, atol=1e-12)


def test_mesh_distance_agrees_with_dense_sampling() -> None:
    v, f = asymmetric_blob(size=0.2, subdivisions=3, seed=1)
    model = MeshModel(v, f)
    rng = np.random.default_rng(1)
    Q = rng.uniform(v.min(0) - 0.03, v.max(0) + 0.03, size=(200, 3))
    c = model.closest(Q)
    dense, _ = sample_surface(v, f, 400_000, seed=7)
    from scipy.spatial import cKDTree

    d_dense, _ = cKDTree(dense).query(Q)
    # Exact distance never exceeds the sampled one, and sampling comes within its spacing.
    spacing = np.sqrt(4 * np.pi * 0.08**2 / 400_000) * 3  # a generous bound on sample gaps
    assert np.all(c.distances <= d_dense + 1e-12)
    assert np.all(d_dense - c.distances < spacing)
    # Closest points lie on the surface: their own distance to the mesh is zero.
    np.testing.assert_allclose(model.closest(c.points).distances, 0.0, atol=1e-12)


def test_sphere_mesh_normals_point_outward() -> None:
    v, f = icosphere(3)
    c = MeshModel(v, f).closest(np.array([[0.0, 0.0, 2.0], [0.1, 0.1, 0.1]]))
    assert c.normals is not None
    assert c.normals[0] @ np.array([0, 0, 1.0]) > 0.99
    assert c.normals[1] @ (np.array([1.0, 1, 1]) / np.sqrt(3)) > 0.95


def test_mesh_normals_beyond_an_edge_follow_the_offset() -> None:
    # A unit cube [0, 1]^3: a point above the top face keeps the face normal; a point beyond
    # the top's edge at x = 1 (closest point on that edge) gets the offset's direction, so
    # its point-to-plane residual is its distance, not the 0 of the top face's plane.
    import trimesh

    cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    cube.apply_translation((0.5, 0.5, 0.5))
    model = MeshModel(cube.vertices, cube.faces)
    p = np.array([[0.3, 0.4, 1.2], [1.3, 0.5, 1.0 + 1e-9], [1.3, 0.5, 1.4], [0.5, 0.5, 0.9]])
    c = model.closest(p)
    assert c.normals is not None
    np.testing.assert_allclose(c.normals[0], [0.0, 0.0, 1.0], atol=1e-12)
    expected = (p[1:3] - [[1.0, 0.5, 1.0], [1.0, 0.5, 1.0]]) / [[0.3], [0.5]]
    np.testing.assert_allclose(c.normals[1:3], expected, atol=1e-6)
    residuals = np.einsum("nd,nd->n", c.normals, p - c.points)
    np.testing.assert_allclose(np.abs(residuals[:3]), [0.2, 0.3, 0.5], atol=1e-9)
    # Inside, under the top face: the face normal, and a negative (inside) residual.
    np.testing.assert_allclose(c.normals[3], [0.0, 0.0, 1.0], atol=1e-12)
    assert residuals[3] == pytest.approx(-0.1, abs=1e-12)


def test_parametric_sphere_distance_is_exact_after_refinement() -> None:
    def sphere(u, v):
        return np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], -1)

    model = ParametricModel(
        sphere, (0, 2 * np.pi), (0, np.pi), periodic_u=True, resolution=(24, 12)
    )
    rng = np.random.default_rng(2)
    Q = rng.normal(size=(300, 3)) * 0.6
    Q = Q[np.linalg.norm(Q, axis=1) > 0.05]
    c = model.closest(Q)
    np.testing.assert_allclose(c.distances, np.abs(np.linalg.norm(Q, axis=1) - 1.0), atol=1e-7)
    # The coarse triangles alone are off by up to ~1 % of the radius at this resolution.
    coarse = ParametricModel(
        sphere,
        (0, 2 * np.pi),
        (0, np.pi),
        periodic_u=True,
        resolution=(24, 12),
        refine_iterations=0,
    )
    assert np.max(np.abs(coarse.closest(Q).distances - np.abs(np.linalg.norm(Q, 1) - 1))) > 1e-4


def test_parametric_ellipsoid_points_project_onto_the_surface() -> None:
    model = ParametricModel(ellipsoid.surface_point, ellipsoid.U_RANGE, ellipsoid.V_RANGE, True)
    rng = np.random.default_rng(3)
    Q = ellipsoid.sample_surface(200, seed=4) * rng.uniform(0.8, 1.2, size=(200, 1))
    c = model.closest(Q)
    a, b, cc = ellipsoid.RADII
    on_surface = (c.points[:, 0] / a) ** 2 + (c.points[:, 1] / b) ** 2 + (c.points[:, 2] / cc) ** 2
    np.testing.assert_allclose(on_surface, 1.0, atol=1e-9)
    # Optimality: the offset is along the surface normal.
    offset = Q - c.points
    normal = c.points / np.array(ellipsoid.RADII) ** 2
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    along = np.abs(np.einsum("nd,nd->n", offset, normal))
    np.testing.assert_allclose(along, np.linalg.norm(offset, axis=1), rtol=1e-6, atol=1e-10)


def test_bad_shapes_are_named() -> None:
    with pytest.raises(InputError, match="NaN or inf"):
        PointModel(np.array([[0.0, 0, 0], [1, np.nan, 0], [0, 1, 0]]))
    with pytest.raises(InputError, match=r"\(F, 3\)"):
        MeshModel(np.eye(3), np.zeros((0, 3), dtype=int))
    with pytest.raises(InputError, match="degenerate"):
        MeshModel(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]))
    with pytest.raises(InputError, match="indices"):
        MeshModel(np.eye(3), np.array([[0, 1, 5]]))
    with pytest.raises(InputError, match="u_range"):
        ParametricModel(ellipsoid.surface_point, (1.0, 0.0), (0.0, 1.0))
