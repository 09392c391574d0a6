"""The real entity: the virtual model plus a seeded model error of the configured magnitude."""

from __future__ import annotations

import igl
import numpy as np
import pytest

from models.model_error import ModelErrorSpec, apply_model_error
from models.model_errors import ModelParameterError
from models.registry import builtin_model, real_model


@pytest.fixture(scope="module")
def skull():
    return builtin_model("skull", seed=0)


def _surface_distance(points: np.ndarray, mesh) -> np.ndarray:
    """Unsigned exact distance [m] from points to the triangles of `mesh` (libigl AABB)."""
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    tree = igl.AABB()
    tree.init(vertices, faces)
    return np.sqrt(tree.squared_distance(vertices, faces, np.asarray(points))[0])


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a**2)))


@pytest.mark.parametrize(
    ("deformation_mm", "noise_mm"), [(0.24, 0.18), (0.4, 0.1), (0.0, 0.3), (0.2, 0.0)]
)
def test_model_error_has_the_configured_magnitude(skull, deformation_mm, noise_mm) -> None:
    spec = ModelErrorSpec(deformation_rms=deformation_mm * 1e-3, noise_rms=noise_mm * 1e-3)
    error = apply_model_error(skull.mesh, spec, seed=3)
    displacement = np.asarray(error.mesh.vertices) - np.asarray(skull.mesh.vertices)
    # Vertex displacement measured from the two meshes: the configured total within 3 %.
    measured = np.sqrt(np.mean(np.sum(displacement**2, axis=1)))
    assert measured == pytest.approx(np.hypot(deformation_mm, noise_mm) * 1e-3, rel=0.03)
    # Distance of the real surface from the virtual one (exact point-triangle distance): the
    # normal noise counts fully, the smooth displacement only by its normal part (about a
    # third of its square), so the RMS lies between those bounds.
    distance = _surface_distance(error.mesh.vertices, skull.mesh)
    lower = np.hypot(0.8 * noise_mm, 0.4 * deformation_mm) * 1e-3
    upper = np.hypot(noise_mm, deformation_mm) * 1e-3 * 1.02
    assert lower <= _rms(distance) <= upper
    assert error.mesh.to_trimesh().is_watertight


def test_default_model_error_is_a_ct_like_0p3_mm(skull) -> None:
    spec = ModelErrorSpec()
    assert 0.2e-3 <= spec.total_rms <= 0.5e-3
    assert spec.total_rms == pytest.approx(0.3e-3, rel=1e-3)
    real, error = real_model(skull, seed=1)
    measured = np.sqrt(np.mean(np.sum(error.displacement**2, axis=1)))
    assert measured == pytest.approx(0.3e-3, rel=0.03)
    # the real entity is never exactly the virtual model
    assert _surface_distance(real.mesh.vertices, skull.mesh).max() > 0.2e-3


def test_deformation_is_smooth_and_noise_is_along_normals(skull) -> None:
    spec = ModelErrorSpec()
    error = apply_model_error(skull.mesh, spec, seed=2)
    edges = skull.mesh.to_trimesh().edges_unique
    v = np.asarray(skull.mesh.vertices)
    length = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    jump = np.linalg.norm(error.deformation[edges[:, 0]] - error.deformation[edges[:, 1]], axis=1)
    noise_jump = np.abs(error.noise[edges[:, 0]] - error.noise[edges[:, 1]])
    # Low frequency: a plane wave of wavelength >= 0.7 * 80 mm changes by at most 2 pi / 56 mm
    # of its amplitude per metre; per millimetre of surface the smooth part changes by a few
    # percent of its RMS, the noise (correlated over 2 mm) by several times more.
    per_mm = 1e-3 / length
    assert np.mean(jump * per_mm) < 0.1 * spec.deformation_rms
    assert np.max(jump * per_mm) < 0.3 * spec.deformation_rms
    assert np.mean(noise_jump * per_mm) > 3 * np.mean(jump * per_mm) * (
        spec.noise_rms / spec.deformation_rms
    )
    np.testing.assert_allclose(np.linalg.norm(error.normals, axis=1), 1.0, atol=1e-9)
    assert abs(error.noise.mean()) < 1e-9
    np.testing.assert_allclose(
        error.displacement, error.deformation + error.noise[:, None] * error.normals
    )


def test_model_error_is_seeded_and_zero_able(skull) -> None:
    a = apply_model_error(skull.mesh, seed=4).mesh.vertices
    b = apply_model_error(skull.mesh, seed=4).mesh.vertices
    c = apply_model_error(skull.mesh, seed=5).mesh.vertices
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-5
    zero = apply_model_error(skull.mesh, ModelErrorSpec(0.0, 0.0), seed=4)
    np.testing.assert_array_equal(zero.mesh.vertices, skull.mesh.vertices)


def test_real_targets_move_with_the_deformation_and_the_virtual_stays(skull) -> None:
    before = skull.mesh.vertices.copy()
    real, error = real_model(skull, seed=6)
    np.testing.assert_array_equal(skull.mesh.vertices, before)
    for virtual_hole, real_hole in zip(skull.burr_holes, real.burr_holes, strict=True):
        moved = real_hole.p_entry - virtual_hole.p_entry
        np.testing.assert_allclose(moved, error.field(virtual_hole.p_entry[None])[0])
        assert 0 < np.linalg.norm(moved) < 1.5e-3
    assert "model error" in real.source


def test_real_parts_keep_their_frames_close() -> None:
    lid = builtin_model("lid")
    real, _ = real_model(lid, seed=0)
    for a, b in zip(lid.frames, real.frames, strict=True):
        assert a.name == b.name
        assert 0 < np.linalg.norm(a.T_part_frame[:3, 3] - b.T_part_frame[:3, 3]) < 1.5e-3


@pytest.mark.parametrize(
    "kwargs",
    [
        {"deformation_rms": -1e-4},
        {"noise_rms": 0.01},
        {"wavelength": 0.0},
        {"noise_correlation": -1.0},
        {"noise_rms": float("nan")},
    ],
)
def test_bad_model_error_specs_are_refused(kwargs) -> None:
    with pytest.raises(ModelParameterError):
        ModelErrorSpec(**kwargs)
