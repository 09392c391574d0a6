"""The skull phantom has no rotational self-symmetry: registration of a scan of it, presented in
random orientations, always returns to the true pose (a mirror symmetry is no rotation)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from models.registry import builtin_model
from registration import MeshModel, match

NOISE = 0.1e-3  # laser range noise [m]


@pytest.fixture(scope="module")
def skull():
    return builtin_model("skull", seed=0)


@pytest.fixture(scope="module")
def mesh_model(skull):
    return MeshModel(np.asarray(skull.mesh.vertices), np.asarray(skull.mesh.faces))


def _scan(skull, count: int, upper_only: bool, seed: int) -> np.ndarray:
    """Points on the phantom (model frame) with Gaussian noise; `upper_only`: what a laser
    above the table sees (faces turned upwards, above the orbits)."""
    tm = skull.mesh.to_trimesh()
    weight = tm.area_faces.copy()
    if upper_only:
        weight *= (tm.face_normals[:, 2] > 0.2) & (tm.triangles_center[:, 2] > -0.01)
    points, _ = trimesh.sample.sample_surface(tm, count, face_weight=weight, seed=seed)
    return points + np.random.default_rng(seed).normal(scale=NOISE, size=points.shape)


def _random_poses(count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    poses = []
    for R in Rotation.random(count, random_state=seed).as_matrix():
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, rng.uniform(-0.5, 0.5, 3)
        poses.append(T)
    return poses


def _pose_error(T_model_data: np.ndarray, T_data_model: np.ndarray) -> tuple[float, float]:
    """Rotation [deg] and translation [m] of T_model_data @ T_data_model (identity if right)."""
    E = T_model_data @ T_data_model
    angle = np.degrees(np.arccos(np.clip((np.trace(E[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)))
    return float(angle), float(np.linalg.norm(E[:3, 3]))


def _data(points: np.ndarray, T_data_model: np.ndarray) -> np.ndarray:
    return points @ T_data_model[:3, :3].T + T_data_model[:3, 3]


def test_whole_scan_returns_to_the_true_pose_from_any_orientation(skull, mesh_model) -> None:
    points = _scan(skull, 1500, upper_only=False, seed=11)
    for T_data_model in _random_poses(12, seed=12):
        result = match(_data(points, T_data_model), mesh_model, mode="global")
        angle, distance = _pose_error(result.T_model_data, T_data_model)
        assert angle < 1.0 and distance < 1e-3, (angle, distance)


def test_upper_surface_scan_returns_to_the_true_pose(skull, mesh_model) -> None:
    points = _scan(skull, 1500, upper_only=True, seed=21)
    for T_data_model in _random_poses(6, seed=22):
        result = match(_data(points, T_data_model), mesh_model, mode="local")
        angle, distance = _pose_error(result.T_model_data, T_data_model)
        assert angle < 1.0 and distance < 1e-3, (angle, distance)
