"""match(): the global minimum from any orientation, outliers, partial overlap, ambiguity,
the verdict, and the predicted TRE against Monte Carlo truth."""

from __future__ import annotations

import numpy as np
import pytest

from registration import (
    InputError,
    MeshModel,
    PointModel,
    match,
    pose_error,
    transform_points,
)
from registration.icp import icp
from registration.synthetic import asymmetric_blob, icosphere, partial_scan

V, F = asymmetric_blob(size=0.2, subdivisions=5, seed=0)
MODEL = MeshModel(V, F)


def _recovered(T, T_truth, deg: float = 0.5, m: float = 0.5e-3) -> bool:
    rot, trans = pose_error(T, T_truth)
    return bool(np.degrees(rot) < deg and trans < m)


@pytest.mark.slow
def test_200_random_orientations_of_a_partial_scan_are_all_recovered() -> None:
    # One side of the object (about 40 % of its surface), 0.1 mm noise, any pose.
    failures = []
    for k in range(200):
        scan = partial_scan(V, F, 400, view=(0.3, -0.2, 1.0), noise=1e-4, seed=1000 + k)
        r = match(scan.points, MODEL, mode="local")
        if not _recovered(r.T_model_data, scan.T_model_data):
            failures.append((k, np.degrees(pose_error(r.T_model_data, scan.T_model_data)[0])))
    assert failures == []


def test_global_mode_on_a_whole_surface_scan() -> None:
    scan = partial_scan(V, F, 1000, min_cosine=-1.0, noise=1e-4, seed=3)
    r = match(scan.points, MODEL, mode="global")
    assert _recovered(r.T_model_data, scan.T_model_data, deg=0.1, m=0.1e-3)
    assert r.verdict == "accepted"
    assert r.inlier_fraction > 0.97


@pytest.mark.parametrize("seed", range(3))
def test_30_percent_outliers_do_not_pull_the_result(seed: int) -> None:
    scan = partial_scan(V, F, 1000, noise=1e-4, outlier_fraction=0.3, seed=20 + seed)
    r = match(scan.points, MODEL, mode="local")
    assert _recovered(r.T_model_data, scan.T_model_data, deg=0.2, m=0.2e-3)
    # The outliers are the points that do not fit: the inlier fraction finds them.
    assert r.inlier_fraction == pytest.approx(0.7, abs=0.05)
    assert r.verdict == "accepted"


def test_a_small_patch_is_registered_locally() -> None:
    # A cap: points whose normal is within ~53 deg of the view, about 20 % of the surface.
    scan = partial_scan(V, F, 600, view=(1.0, 0.2, 0.4), min_cosine=0.6, noise=1e-4, seed=7)
    r = match(scan.points, MODEL, mode="local")
    assert _recovered(r.T_model_data, scan.T_model_data, deg=0.5, m=0.5e-3)


def test_a_sphere_is_ambiguous() -> None:
    v, f = icosphere(4)
    sphere = MeshModel(0.1 * v, f)
    scan = partial_scan(0.1 * v, f, 500, noise=1e-4, seed=5)
    r = match(scan.points, sphere, mode="local")
    assert r.verdict == "ambiguous"
    assert [s.kind for s in r.symmetries] == ["sphere"]
    np.testing.assert_allclose(r.symmetries[0].point, 0.0, atol=1e-4)


def test_a_scan_of_another_object_is_not_accepted() -> None:
    other_v, other_f = asymmetric_blob(size=0.2, subdivisions=5, seed=11)
    scan = partial_scan(other_v, other_f, 800, noise=1e-4, seed=9)
    r = match(scan.points, MODEL, mode="local")
    assert r.verdict != "accepted"


def test_point_model_and_mesh_model_agree() -> None:
    scan = partial_scan(V, F, 800, noise=1e-4, seed=12)
    from registration.shapes.mesh_shape import sample_surface

    pts, normals = sample_surface(V, F, 40_000, seed=2)
    r_points = match(scan.points, PointModel(pts, normals), mode="local")
    assert _recovered(r_points.T_model_data, scan.T_model_data)


def test_predicted_tre_matches_monte_carlo_spread() -> None:
    """The predicted TRE is the RMS target error over noise draws (independent truth)."""
    scan = partial_scan(V, F, 300, view=(0.0, 0.3, 1.0), noise=0.0, seed=30)
    targets = np.array([[0.0, 0.0, 0.0], [0.08, 0.02, 0.03], [-0.05, -0.04, 0.02]])
    sigma = 5e-4
    rng = np.random.default_rng(31)
    errors, predicted = [], []
    for _ in range(40):
        noisy = scan.points + rng.normal(scale=sigma, size=scan.points.shape)
        r = match(noisy, MODEL, mode="refine", T_init=scan.T_model_data)
        # Target error: where the estimate puts the data-frame image of each model target.
        T_err = r.T_model_data @ np.linalg.inv(scan.T_model_data)
        errors.append(np.linalg.norm(transform_points(T_err, targets) - targets, axis=1))
        predicted.append(r.predicted_tre(targets).tre)
    measured = np.sqrt(np.mean(np.square(errors), axis=0))
    ratio = measured / np.mean(predicted, axis=0)
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio


def test_result_is_a_rigid_transform_with_consistent_fields() -> None:
    scan = partial_scan(V, F, 500, noise=1e-4, seed=40)
    r = match(scan.points, MODEL)
    R = r.T_model_data[:3, :3]
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(r.T_model_data[3], [0, 0, 0, 1])
    assert 0.0 <= r.ambiguity <= 1.0
    if r.second is None:  # every start that got through ended in the best pose
        assert r.ambiguity == 0.0
    else:
        assert r.second.cost >= r.best.cost
    assert r.covariance.shape == (6, 6)
    assert np.all(np.linalg.eigvalsh(r.covariance) > 0)
    assert len(r.history) == r.iterations == len(r.trajectory)
    assert r.starts > 1000


def test_point_order_does_not_change_the_result() -> None:
    scan = partial_scan(V, F, 500, noise=1e-4, seed=41)
    perm = np.random.default_rng(0).permutation(len(scan.points))
    a = match(scan.points, MODEL).T_model_data
    b = match(scan.points[perm], MODEL).T_model_data
    rot, trans = pose_error(a, b)
    assert np.degrees(rot) < 0.02 and trans < 2e-5


def test_the_search_ends_in_the_minimum_icp_reaches_from_the_truth() -> None:
    scan = partial_scan(V, F, 500, noise=2e-4, seed=42)
    r = match(scan.points, MODEL)
    from_truth = icp(scan.points, MODEL, scan.T_model_data)
    rot, trans = pose_error(r.T_model_data, from_truth.T_model_data)
    assert np.degrees(rot) < 0.005 and trans < 5e-6


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (np.array([[0.0, 0, 0], [1, 1, 1]]), "at least 3"),
        (np.array([[0.0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]]), "one line"),
        (np.array([[0.0, 0, 0], [1, np.inf, 1], [2, 0, 2]]), "NaN or inf"),
        (np.zeros((4, 2)), r"\(N, 3\)"),
    ],
)
def test_bad_data_is_named(data: np.ndarray, message: str) -> None:
    with pytest.raises(InputError, match=message):
        match(data, MODEL)


def test_bad_options_are_named() -> None:
    pts = partial_scan(V, F, 50, seed=1).points
    with pytest.raises(InputError, match="auto, global, local, refine"):
        match(pts, MODEL, mode="sideways")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="T_init"):
        match(pts, MODEL, mode="refine")
    with pytest.raises(InputError, match="model must be"):
        match(pts, "skull.stl")
    from registration.quality import ScanPasses

    with pytest.raises(InputError, match="one pass per data point"):
        match(pts, MODEL, passes=ScanPasses(np.zeros(3, dtype=int), 3e-4))


def _deformed(vertices: np.ndarray, faces: np.ndarray, rms: float, seed: int) -> np.ndarray:
    """The blob with a smooth random deformation along its normals (plane waves, ~60 mm)."""
    import trimesh

    normals = trimesh.Trimesh(vertices, faces, process=False).vertex_normals
    rng = np.random.default_rng(seed)
    k = rng.normal(size=(6, 3))
    k *= 2 * np.pi / 0.06 / np.linalg.norm(k, axis=1, keepdims=True)
    field = np.sum(np.sin(vertices @ k.T + rng.uniform(0, 2 * np.pi, 6)), axis=1)
    field *= rms / np.sqrt(np.mean(field**2))
    return vertices + normals * field[:, None]


def test_predicted_tre_accounts_for_correlated_model_error() -> None:
    """Under a smooth model error the residuals are correlated: the prediction must widen
    accordingly. Truth: the RMS target error over 24 independent deformations."""
    targets = np.array([[0.0, 0.0, 0.0], [0.08, 0.02, 0.03], [-0.05, -0.04, 0.02]])
    errors, predicted = [], []
    for k in range(24):
        real = _deformed(V, F, 3e-4, seed=200 + k)
        scan = partial_scan(real, F, 1500, view=(0.0, 0.3, 1.0), noise=1e-4, seed=300 + k)
        r = match(scan.points, MODEL, mode="refine", T_init=scan.T_model_data)
        T_err = r.T_model_data @ np.linalg.inv(scan.T_model_data)
        errors.append(np.linalg.norm(transform_points(T_err, targets) - targets, axis=1))
        predicted.append(r.predicted_tre(targets).tre)
    measured = np.sqrt(np.mean(np.square(errors), axis=0))
    ratio = measured / np.sqrt(np.mean(np.square(predicted), axis=0))
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio


def _three_pass_scan(k: int, offset: float):
    """Three passes of the blob in one data frame, each pass shifted by its own offset."""
    from registration.rigid import random_transform

    rng = np.random.default_rng(500 + k)
    T_data_model = random_transform(rng, 0.1)
    parts, labels = [], []
    for g, view in enumerate([(0.0, 0.0, 1.0), (1.0, 0.0, 0.5), (-1.0, 0.3, 0.5)]):
        scan = partial_scan(V, F, 500, view=view, min_cosine=0.4, noise=5e-5, seed=600 + 3 * k + g)
        p_model = transform_points(scan.T_model_data, scan.points)
        p_model += rng.normal(scale=offset, size=3)  # the pass's rigid offset
        parts.append(transform_points(T_data_model, p_model))
        labels.append(np.full(len(p_model), g))
    return np.vstack(parts), np.concatenate(labels), np.linalg.inv(T_data_model)


def test_predicted_tre_accounts_for_rigid_offsets_of_scan_passes() -> None:
    """Three passes, each displaced as a whole by the arm's error (0.3 mm per axis): the
    covariance takes the offsets from `ScanPasses`. Truth: 24 independent draws."""
    from registration.quality import ScanPasses

    targets = np.array([[0.0, 0.0, 0.0], [0.08, 0.02, 0.03], [-0.05, -0.04, 0.02]])
    errors, predicted = [], []
    for k in range(24):
        data, labels, T_truth = _three_pass_scan(k, offset=3e-4)
        passes = ScanPasses(labels, sigma_offset=3e-4)
        r = match(data, MODEL, mode="refine", T_init=T_truth, passes=passes)
        T_err = r.T_model_data @ np.linalg.inv(T_truth)
        errors.append(np.linalg.norm(transform_points(T_err, targets) - targets, axis=1))
        predicted.append(r.predicted_tre(targets).tre)
    measured = np.sqrt(np.mean(np.square(errors), axis=0))
    ratio = measured / np.sqrt(np.mean(np.square(predicted), axis=0))
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio


def test_the_judge_prefers_the_pose_that_explains_the_whole_scan() -> None:
    # The L-bracket seen from above and both sides (its end faces), in its own frame: the
    # true pose is the identity. Slid 4 mm along its length, the scan still lies on the
    # model but for the strip beyond the end face (about 5 % of it). Handed the slid pose
    # as the better one, the judge prefers the other and finds no rival.
    from models.registry import builtin_model
    from registration.judge import Judge
    from registration.search import SearchSettings

    bracket = builtin_model("bracket")
    shape = MeshModel(bracket.mesh.vertices, bracket.mesh.faces)
    scans = [
        partial_scan(bracket.mesh.vertices, bracket.mesh.faces, 1500, view=v, min_cosine=0.3,
                     noise=5e-5, seed=k, translation_scale=0.0)
        for k, v in enumerate(((0.0, 0.0, 1.0), (1.0, 0.0, 0.6), (-1.0, 0.0, 0.6)))
    ]  # fmt: skip
    data = np.vstack([transform_points(s.T_model_data, s.points) for s in scans])  # model frame
    T_slid = np.eye(4)
    T_slid[0, 3] = 0.004
    settings = SearchSettings()
    rng = np.random.default_rng(1)
    judge = Judge(data, shape.closest, settings, 1e-6, rng)
    verdict = judge(T_slid, [np.eye(4)])
    assert verdict.rival_wins and verdict.ambiguity == 0.0
    # Two equally good poses (the same one twice) stay a tie: ambiguity 1.
    tie = judge(np.eye(4), [np.eye(4)])
    assert not tie.rival_wins and tie.ambiguity == pytest.approx(1.0)
    # The rival counts at its most competitive pose: slid or not, the true one is a tie.
    both = judge(np.eye(4), [T_slid, np.eye(4)])
    assert both.rival == 1 and both.ambiguity == pytest.approx(1.0)
