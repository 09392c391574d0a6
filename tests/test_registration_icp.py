"""ICP (eq. 19-23): known transforms recovered against points, meshes and parametric
surfaces; no one-to-one correspondence; the stopping rule; robust weights."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from registration import L2, MeshModel, ParametricModel, PointModel, pose_error
from registration.icp import icp
from registration.rigid import invert, make_T, transform_points
from registration.shapes.mesh_shape import sample_surface
from registration.synthetic import asymmetric_blob

BLOB_V, BLOB_F = asymmetric_blob(size=0.2, subdivisions=4, seed=2)


def _offset(deg: float, mm: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    d = rng.normal(size=3)
    return make_T(
        Rotation.from_rotvec(np.radians(deg) * axis).as_matrix(), mm * 1e-3 * d / np.linalg.norm(d)
    )


def _scan(count: int, seed: int, noise: float = 0.0):
    pts, _ = sample_surface(BLOB_V, BLOB_F, count, seed=seed)
    rng = np.random.default_rng(seed)
    T_data_model = make_T(
        Rotation.random(random_state=rng).as_matrix(), rng.normal(scale=0.1, size=3)
    )
    pts = pts + rng.normal(scale=noise, size=pts.shape) if noise else pts
    return transform_points(T_data_model, pts), invert(T_data_model)


@pytest.mark.parametrize("variant", ["point_to_point", "point_to_plane"])
def test_mesh_recovers_a_known_transform_exactly(variant: str) -> None:
    data, T_truth = _scan(800, seed=1)
    model = MeshModel(BLOB_V, BLOB_F)
    r = icp(data, model, _offset(8.0, 10.0) @ T_truth, variant=variant, max_iterations=500)
    rot, trans = pose_error(r.T_model_data, T_truth)
    assert r.converged
    if variant == "point_to_plane":
        # Noise-free data on the exact surface: the only limit is the stopping threshold.
        assert np.degrees(rot) < 1e-3 and trans < 1e-5
    else:
        # Point-to-point creeps along the surface (linear convergence): it meets the stopping
        # rule while still a little off, a known weakness of Besl's variant.
        assert np.degrees(rot) < 0.2 and trans < 0.3e-3


def test_point_sets_of_different_sizes_without_correspondence() -> None:
    model_pts, _ = sample_surface(BLOB_V, BLOB_F, 30_000, seed=5)  # a different sample
    data, T_truth = _scan(500, seed=2)
    r = icp(data, PointModel(model_pts), _offset(6.0, 8.0, seed=1) @ T_truth)
    rot, trans = pose_error(r.T_model_data, T_truth)
    # Model points ~1 mm apart; point-to-plane on estimated normals removes most of that bias.
    assert np.degrees(rot) < 0.2 and trans < 0.5e-3


def _bumpy(u, v):
    s = 1.0 + 0.25 * np.sin(2 * u) * np.sin(v) ** 2 + 0.15 * np.cos(3 * v) + 0.1 * np.cos(u)
    return (
        0.1
        * s[..., None]
        * np.stack([np.cos(u) * np.sin(v), 0.7 * np.sin(u) * np.sin(v), 0.5 * np.cos(v)], -1)
    )


def test_parametric_surface_recovers_a_known_transform() -> None:
    model = ParametricModel(_bumpy, (0, 2 * np.pi), (0, np.pi), periodic_u=True)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0, 2 * np.pi, 400), np.arccos(rng.uniform(-1, 1, 400))
    pts = _bumpy(u, v)
    T_truth = make_T(Rotation.random(random_state=rng).as_matrix(), [0.05, -0.02, 0.1])
    data = transform_points(invert(T_truth), pts)
    r = icp(data, model, _offset(5.0, 5.0, seed=2) @ T_truth, max_iterations=100)
    rot, trans = pose_error(r.T_model_data, T_truth)
    # Exact points on the analytic surface: recovered far below the triangles' own error.
    assert np.degrees(rot) < 1e-4 and trans < 1e-6


def test_stopping_rule_and_history() -> None:
    data, T_truth = _scan(500, seed=4, noise=1e-4)
    model = MeshModel(BLOB_V, BLOB_F)
    tau = 1e-14
    r = icp(data, model, _offset(5.0, 5.0) @ T_truth, tau=tau, max_iterations=100)
    assert r.converged
    assert abs(r.mse_history[-1] - r.mse_history[-2]) < tau
    assert np.all(np.abs(np.diff(r.mse_history[:-1])) >= tau)  # it did not stop earlier
    capped = icp(data, model, _offset(5.0, 5.0) @ T_truth, tau=0.0, max_iterations=3)
    assert not capped.converged and capped.iterations == 3


@pytest.mark.parametrize("variant", ["point_to_point", "point_to_plane"])
def test_robust_weights_in_every_variant(variant: str) -> None:
    data, T_truth = _scan(600, seed=6, noise=1e-4)
    rng = np.random.default_rng(6)
    data[:150] += rng.uniform(-0.05, 0.05, size=(150, 3))  # 25 % gross outliers
    model = MeshModel(BLOB_V, BLOB_F)
    start = _offset(3.0, 3.0) @ T_truth
    robust = icp(data, model, start, variant=variant, max_iterations=400)
    plain = icp(data, model, start, variant=variant, kernel=L2(), max_iterations=400)
    rot, trans = pose_error(robust.T_model_data, T_truth)
    tolerance = (0.05, 0.1e-3) if variant == "point_to_plane" else (0.15, 0.3e-3)
    assert np.degrees(rot) < tolerance[0] and trans < tolerance[1]
    assert pose_error(plain.T_model_data, T_truth)[1] > 3 * trans
    assert np.mean(robust.weights[:150] == 0) > 0.8
