"""The register-stage trial: the evaluator against analytic errors, the simulated scan
against the geometry of spheres, and a noiseless trial against the truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.registry import builtin_model
from registration import invert, make_T
from registration.synthetic import icosphere
from scenarios.campaign.evaluate import evaluate_registration
from scenarios.campaign.register_config import default_register_config
from scenarios.campaign.register_stage import longest_pass_gap, run_register_trial
from scenarios.campaign.simscan import ScanErrors, simulate_scan

NO_ERRORS = ScanErrors(range_sigma=0.0, pass_sigma=0.0, pass_rotation_sigma=0.0, jitter_sigma=0.0)


def test_evaluator_errors_match_a_known_rotation() -> None:
    """A pose wrong by a turn of theta about the model's z axis moves a target p by
    2 |p_xy| sin(theta / 2) (analytic)."""
    theta = np.deg2rad(3.0)
    T_table_object = make_T(
        Rotation.from_euler("xyz", [0.1, -0.2, 0.7]).as_matrix(), [0.3, -0.1, 0.2]
    )
    D = make_T(Rotation.from_euler("z", theta).as_matrix(), np.zeros(3))
    estimate = invert(T_table_object @ D)  # table -> model
    targets = np.array([[0.05, 0.0, 0.01], [0.0, -0.02, 0.03], [0.0, 0.0, 0.04]])
    expected = 2 * np.linalg.norm(targets[:, :2], axis=1) * np.sin(theta / 2)
    ev = evaluate_registration(
        estimate, T_table_object, targets, targets, np.zeros(3), np.full(3, 1e-3),
        accepted=True, right_object=True, threshold=2e-3,
    )  # fmt: skip
    np.testing.assert_allclose(ev.target_error, expected, atol=1e-12)
    np.testing.assert_allclose(ev.tre_ratio, expected / 1e-3, rtol=1e-12, atol=1e-9)
    assert ev.rotation_error == pytest.approx(theta, abs=1e-9)
    assert ev.centroid_error == pytest.approx(0.0, abs=1e-12)
    assert expected.max() > 2e-3  # the first target moved 2.6 mm: a false accept
    assert ev.false_accept and not ev.good
    ev = evaluate_registration(
        estimate, T_table_object, targets, targets, np.zeros(3), np.full(3, 1e-3),
        accepted=True, right_object=True, threshold=3e-3,
    )  # fmt: skip
    assert ev.good and not ev.false_accept
    wrong = evaluate_registration(
        invert(T_table_object), T_table_object, targets, targets, np.zeros(3), np.full(3, 1e-3),
        accepted=True, right_object=False, threshold=2e-3,
    )  # fmt: skip
    assert wrong.target_error.max() == pytest.approx(0.0, abs=1e-12)
    assert wrong.false_accept  # an accept of the wrong object is false whatever its errors


def _sphere(radius: float, centre: tuple[float, float, float], offset: int = 0):
    v, f = icosphere(5)
    return v * radius + np.array(centre), f + offset


def test_top_view_of_a_sphere_sees_the_cap_within_the_grazing_limit() -> None:
    """Area fraction of a sphere's cap of polar angle <= 75 deg: (1 - cos 75 deg) / 2."""
    v, f = _sphere(0.05, (0.0, 0.0, 0.0))
    T = make_T(np.eye(3), [0.1, 0.2, 0.3])
    scan = simulate_scan(
        v, f, T, (0.0,), 2000, NO_ERRORS, np.random.default_rng(0), samples=100_000
    )
    assert scan.surface_fraction == pytest.approx((1 - np.cos(np.deg2rad(75))) / 2, abs=0.01)
    p = scan.points - T[:3, 3]
    assert np.abs(np.linalg.norm(p, axis=1) - 0.05).max() < 1e-4  # on the sphere (facets)
    assert (p[:, 2] / 0.05).min() > np.cos(np.deg2rad(75)) - 0.01  # within the grazing limit
    assert len(scan.points) == 2000 and scan.inlier.all()


def test_the_depth_buffer_hides_a_sphere_under_another() -> None:
    v1, f1 = _sphere(0.05, (0.0, 0.0, 0.2))
    v2, f2 = _sphere(0.05, (0.0, 0.0, 0.0), offset=len(v1))
    v, f = np.vstack([v1, v2]), np.vstack([f1, f2])
    scan = simulate_scan(
        v, f, np.eye(4), (0.0,), 3000, NO_ERRORS, np.random.default_rng(1), samples=200_000
    )
    assert scan.points[:, 2].min() > 0.2  # nothing of the lower sphere, only the upper cap


def test_outliers_and_small_patch() -> None:
    v, f = _sphere(0.05, (0.0, 0.0, 0.0))
    errors = ScanErrors(outlier_fraction=0.3)
    scan = simulate_scan(
        v, f, np.eye(4), (0.0, 45.0), 1000, errors, np.random.default_rng(2), coverage=0.1
    )
    assert (~scan.inlier).sum() == 300
    assert scan.surface_fraction == pytest.approx(0.1, abs=1e-3)
    assert scan.inlier.sum() == 700


def test_noiseless_skull_trial_finds_the_true_pose() -> None:
    config = default_register_config()
    config["laser"]["sigma"] = 0.0
    config["arm"] = {"pass_sigma": 0.0, "pass_rotation_sigma": 0.0, "jitter_sigma": 0.0}
    config["model_error"] = {"deformation_rms_m": 0.0, "noise_rms_m": 0.0}
    config["scan"]["points"] = 1500
    row = run_register_trial(config, seed=4)
    assert row["verdict"] == "accepted"
    assert row["target_error_max_m"] < 5e-5  # facets of the scanned surface only
    assert row["rotation_error_rad"] < 1e-3
    assert row["false_accept"] == 0 and row["good"] == 1
    assert row["n_targets"] == 4 and len(row["targets"].split(";")) == 4


def test_scan_faults_in_a_registration_trial():
    """A dropout burst (30 % of one pass's sweep) leaves a gap the trial sees; a shiny patch's
    returns (10 mm too long) lie off the matched model; both are left out and the match is
    accepted within the goal. Ground truth: the simulated scan (what was lost, what is
    spurious) and the trial's evaluator (the true pose)."""

    for name in ("laser_dropout_burst", "laser_spurious"):
        config = default_register_config()
        config["faults"] = {name: True}
        row = run_register_trial(config, 0)
        assert row[f"fault.{name}"] == "recovered" and row[f"fault.{name}.stage"] == "register"
        assert row["verdict"] == "accepted" and row["target_error_max_m"] < 1e-3
        assert row["harmed"] == 0


def test_a_whole_scan_has_no_pass_gap():
    """The gap check is silent on scans that lost nothing (seeds 0-4) and sees a burst."""

    skull = builtin_model("skull", 0)
    for seed in range(5):
        for burst in (0.0, 0.3):
            scan = simulate_scan(
                skull.mesh.vertices, skull.mesh.faces, np.eye(4), (0.0, 55.0, 70.0), 3000,
                ScanErrors(dropout_burst=burst), np.random.default_rng(seed),
            )  # fmt: skip
            gap = longest_pass_gap(scan.points, scan.pass_index)
            assert (gap > 0.0) == (burst > 0.0), (seed, burst, gap)
