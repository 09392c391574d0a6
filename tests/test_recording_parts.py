"""The recording's pieces on data with a known answer: residuals against displaced surface
points, TRE ellipsoids against their covariance, poses kept only when they change."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from models.registry import builtin_model
from scenarios.outputs.residuals import OFF_MODEL_M, signed_residuals
from scenarios.realcell.recording.recorded_scene import MOVED, CellScene
from scenarios.realcell.recording.recorded_targets import ellipsoids, magnification


def test_signed_residuals_recover_known_offsets() -> None:
    """Skull vertices moved along their normals by known distances (up to 0.3 mm either
    way, a fit's residuals): the residuals give them back with their sign, 99 % within
    10 um and all within 0.1 mm (the surface's curvature over the offset); beyond
    OFF_MODEL_M a point is off the model (inf)."""
    virtual = builtin_model("skull")
    mesh = trimesh.Trimesh(virtual.mesh.vertices, virtual.mesh.faces, process=False)
    rng = np.random.default_rng(3)
    k = rng.integers(0, len(mesh.vertices), 3000)
    offset = rng.uniform(-3e-4, 3e-4, len(k))
    p = mesh.vertices[k] + offset[:, None] * mesh.vertex_normals[k]
    residuals, normals = signed_residuals(virtual, p)
    assert np.all(np.isfinite(residuals))
    error = np.abs(residuals - offset)
    assert np.quantile(error, 0.99) < 1e-5 and error.max() < 1e-4
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    far = mesh.vertices[k[:10]] + 2 * OFF_MODEL_M * mesh.vertex_normals[k[:10]]
    assert np.all(np.isinf(signed_residuals(virtual, far)[0]))


def test_ellipsoids_are_their_covariances() -> None:
    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 3, 3)) * 1e-4
    cov = A @ A.transpose(0, 2, 1)
    half, xyzw = ellipsoids(cov, 20.0)
    R = Rotation.from_quat(xyzw).as_matrix()
    rebuilt = R @ (np.eye(3) * (half / 20.0)[:, None, :] ** 2) @ R.transpose(0, 2, 1)
    np.testing.assert_allclose(rebuilt, cov, rtol=1e-9, atol=1e-20)
    assert np.allclose(np.linalg.det(R), 1.0)


@pytest.mark.parametrize(("worst_m", "factor"), [(0.3e-3, 50), (0.0, 200), (20e-3, 1), (1e-3, 10)])
def test_magnification_keeps_the_longest_line_short(worst_m: float, factor: int) -> None:
    assert magnification(np.array([worst_m / 2, worst_m])) == factor


class _Columns:
    def __init__(self) -> None:
        self.sent: dict[str, np.ndarray] = {}

    def columns(self, path: str, times: np.ndarray, columns: Any, timeline: str = "") -> None:
        self.sent[path] = np.asarray(times)


def test_poses_sent_when_they_change_and_true_at_every_sample() -> None:
    """A body at rest, then moving, then at rest again (30 Hz samples): the poses kept are
    few, and the latest kept pose at every sample time is that sample's pose."""
    t = np.arange(300) / 30.0
    s = np.clip((t - 3.0) / 2.0, 0.0, 1.0)  # moves from 3 s to 5 s
    pos = np.stack([0.5 * s, np.zeros_like(s), np.full_like(s, 0.4)], axis=1)
    xyzw = Rotation.from_euler("z", 0.3 * s[:, None]).as_quat()
    sink = _Columns()
    CellScene._send(sink, "world/cell/table", t, pos, xyzw)  # type: ignore[arg-type]
    kept = np.searchsorted(t, sink.sent["world/cell/table"])
    assert len(kept) < 100  # the rests are not sent again at every sample
    latest = kept[np.searchsorted(kept, np.arange(len(t)), side="right") - 1]
    assert np.max(np.abs(pos[latest] - pos)) <= MOVED
