"""Auto mode, the default: a scan covering anything from 15 % to all of the surface, with
or without 40 % spurious points, found from any orientation without choosing a mode; and
the explicit modes, each on the data it is for."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from models.registry import builtin_model
from registration import MeshModel, match, pose_error, transform_points
from registration.synthetic import asymmetric_blob, partial_scan

BLOB = asymmetric_blob(size=0.15, subdivisions=5, seed=3)
#: min_cosine of partial_scan and the share of the surface it keeps on these shapes.
COVERAGE = {"15%": 0.7, "30%": 0.4, "60%": -0.2, "100%": -1.0}


@pytest.fixture(scope="module")
def skull():
    mesh = builtin_model("skull", seed=0).mesh
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def _right(T: np.ndarray, T_truth: np.ndarray, points: np.ndarray) -> bool:
    d = transform_points(T, points) - transform_points(T_truth, points)
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1)))) < 1e-3


@pytest.mark.parametrize("outliers", [0.0, 0.4])
@pytest.mark.parametrize("coverage", list(COVERAGE))
@pytest.mark.parametrize("shape", ["blob", "skull"])
def test_auto_mode_any_coverage_any_orientation(shape, coverage, outliers, skull) -> None:
    v, f = BLOB if shape == "blob" else skull
    model = MeshModel(v, f)
    rng = np.random.default_rng(zlib.crc32(f"{shape} {coverage} {outliers}".encode()))
    misses = []
    for k in range(6):
        view = rng.normal(size=3)
        scan = partial_scan(v, f, 2000, view=view, min_cosine=COVERAGE[coverage], noise=1e-4,
                            outlier_fraction=outliers, seed=int(rng.integers(1 << 30)))  # fmt: skip
        r = match(scan.points, model)
        if not _right(r.T_model_data, scan.T_model_data, scan.points[scan.inlier]):
            misses.append((k, r.verdict))
    assert misses == []


def test_global_mode_does_not_rest_on_the_centroid() -> None:
    # A whole-surface scan with 40 % of spurious points in a box beside the object (a
    # reflection): the data's centroid moves by a good part of the object's size. Global
    # mode centres its rotations on the surface points.
    v, f = BLOB
    model = MeshModel(v, f)
    rng = np.random.default_rng(5)
    for seed in range(3):
        scan = partial_scan(v, f, 1200, min_cosine=-1.0, noise=1e-4, seed=50 + seed)
        lo, hi = scan.points.min(axis=0), scan.points.max(axis=0)
        beside = rng.uniform(lo, hi, size=(800, 3)) + np.array([0.8 * (hi - lo)[0], 0.0, 0.0])
        data = np.vstack([scan.points, beside])
        shift = np.linalg.norm(data.mean(axis=0) - scan.points.mean(axis=0))
        assert shift > 0.02
        r = match(data, model, mode="global")
        assert _right(r.T_model_data, scan.T_model_data, scan.points)
        assert r.verdict == "accepted", r.reason


def test_local_and_refine_modes_stay_available() -> None:
    v, f = BLOB
    model = MeshModel(v, f)
    scan = partial_scan(v, f, 1500, min_cosine=0.4, noise=1e-4, seed=60)
    local = match(scan.points, model, mode="local")
    assert _right(local.T_model_data, scan.T_model_data, scan.points)
    # Refine starts from the guess and searches no rival: its verdict says so.
    guess = local.T_model_data.copy()
    guess[:3, 3] += 0.002
    refined = match(scan.points, model, mode="refine", T_init=guess)
    assert _right(refined.T_model_data, scan.T_model_data, scan.points)
    assert refined.verdict == "accepted" and "no rival searched" in refined.reason
    assert refined.starts == 1 and refined.second is None


def test_the_guess_is_used_in_every_mode() -> None:
    # A small patch that the search alone may leave ambiguous: the right guess is one more
    # candidate, and a wrong guess does not win over the search.
    v, f = BLOB
    model = MeshModel(v, f)
    scan = partial_scan(v, f, 1500, min_cosine=0.5, noise=1e-4, seed=61)
    for mode in ("auto", "global", "local"):
        r = match(scan.points, model, mode=mode, T_init=scan.T_model_data)
        rot, _ = pose_error(r.T_model_data, scan.T_model_data)
        assert np.degrees(rot) < 0.2, mode
    wrong = np.eye(4)
    r = match(scan.points, model, T_init=wrong)
    assert _right(r.T_model_data, scan.T_model_data, scan.points)


def test_same_data_and_seed_same_result_bit_for_bit() -> None:
    v, f = BLOB
    scan = partial_scan(v, f, 5000, min_cosine=0.2, noise=1e-4, outlier_fraction=0.2, seed=62)
    a = match(scan.points, MeshModel(v, f), seed=3)
    b = match(scan.points, MeshModel(v, f), seed=3)
    np.testing.assert_array_equal(a.T_model_data, b.T_model_data)
    np.testing.assert_array_equal(a.covariance, b.covariance)
    assert (a.rms, a.ambiguity, a.starts, a.verdict) == (b.rms, b.ambiguity, b.starts, b.verdict)
    # The default seed is fixed (0), and another seed draws other subsamples.
    assert match(scan.points, MeshModel(v, f)).seed == 0
    c = match(scan.points, MeshModel(v, f), seed=4)
    assert not np.array_equal(a.T_model_data, c.T_model_data)
    assert _right(c.T_model_data, scan.T_model_data, scan.points[scan.inlier])
