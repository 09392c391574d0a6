"""Implicit solids and their meshing, checked against closed forms and brute force."""

from __future__ import annotations

import numpy as np
import pytest

import models.implicit as implicit
from models.model_errors import ModelParameterError


def _sphere(p: np.ndarray) -> np.ndarray:
    return np.linalg.norm(p, axis=1) - 30.0


def test_marching_cubes_of_a_sphere_is_closed_and_on_the_sphere() -> None:
    mesh = implicit.mesh_implicit(_sphere, np.full(3, -35.0), np.full(3, 35.0), 1.0)
    assert mesh.is_watertight and mesh.volume > 0
    r = np.linalg.norm(mesh.vertices, axis=1)
    assert np.abs(r - 30.0).max() < 0.05  # linear interpolation of an exact distance
    assert mesh.volume == pytest.approx(4 / 3 * np.pi * 30.0**3, rel=0.01)


def test_narrow_band_gives_the_same_mesh_as_full_evaluation(monkeypatch) -> None:
    lower, upper = np.array([-40.0, -30.0, -30.0]), np.array([40.0, 30.0, 30.0])

    def shape(p: np.ndarray) -> np.ndarray:  # a peanut: two blended balls, a dent between
        a = implicit.ellipsoid(p, np.array([-15.0, 0, 0]), np.array([20.0, 18, 16]))
        b = implicit.ellipsoid(p, np.array([15.0, 0, 0]), np.array([18.0, 15, 15]))
        return implicit.smooth_union(a, b, 4.0)

    banded = implicit.mesh_implicit(shape, lower, upper, 1.3)
    monkeypatch.setattr(implicit, "_BAND", np.inf)
    full = implicit.mesh_implicit(shape, lower, upper, 1.3)
    np.testing.assert_array_equal(banded.faces, full.faces)
    np.testing.assert_allclose(banded.vertices, full.vertices, atol=1e-12)


def test_tube_is_the_exact_distance_to_a_polyline_clipped_at_cap() -> None:
    rng = np.random.default_rng(0)
    path = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 5]])
    p = rng.uniform(-20, 30, size=(500, 3))
    # brute force: distance to many points along the polyline
    s = np.linspace(0, 1, 4001)[:, None]
    dense = np.vstack([path[0] + s * (path[1] - path[0]), path[1] + s * (path[2] - path[1])])
    brute = np.min(np.linalg.norm(p[:, None, :] - dense[None], axis=2), axis=1) - 2.0
    got = implicit.tube(p, path, np.array([2.0, 2.0, 2.0]), cap=8.0)
    np.testing.assert_allclose(got, np.minimum(brute, 8.0), atol=5e-3)
    tapered = implicit.tube(p, path[:2], np.array([1.0, 3.0]))
    t = np.clip(p[:, 0] / 10.0, 0, 1)
    axis_distance = np.linalg.norm(p - np.column_stack([10 * t, 0 * t, 0 * t]), axis=1)
    np.testing.assert_allclose(tapered, axis_distance - (1.0 + 2.0 * t))


def test_smooth_operations_bound_the_sharp_ones() -> None:
    a, b = np.linspace(-5, 5, 101), np.linspace(5, -5, 101)
    union = implicit.smooth_union(a, b, 2.0)
    assert (union <= np.minimum(a, b) + 1e-12).all()
    assert (union >= np.minimum(a, b) - 2.0 / 4 - 1e-12).all()  # at most k/4 deeper
    far = np.abs(a - b) >= 2.0
    np.testing.assert_allclose(union[far], np.minimum(a, b)[far])
    assert (implicit.smooth_subtract(a, b, 2.0) >= np.maximum(a, -b) - 1e-12).all()
    assert (implicit.smooth_intersect(a, b, 2.0) >= np.maximum(a, b) - 1e-12).all()


def test_meshing_refuses_a_box_that_cuts_the_solid() -> None:
    with pytest.raises(ModelParameterError, match="boundary"):
        implicit.mesh_implicit(_sphere, np.full(3, -20.0), np.full(3, 20.0), 1.0)
    with pytest.raises(ModelParameterError, match="spacing"):
        implicit.mesh_implicit(_sphere, np.full(3, -35.0), np.full(3, 35.0), 0.0)
