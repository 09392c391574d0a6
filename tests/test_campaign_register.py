"""The register-stage trial: the evaluator against analytic errors, the simulated scan
against the geometry of spheres, a noiseless trial against the truth, its job configuration
(what it reads, what it refuses) and its row's columns."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.registry import builtin_model
from registration import invert, make_T
from registration.synthetic import icosphere
from scenarios.campaign.campaign_errors import CampaignError
from scenarios.campaign.evaluate import evaluate_registration
from scenarios.campaign.register_job import ScanFaultAmounts, parse_register_job, register_base
from scenarios.campaign.register_row import ScanFaultOutcome
from scenarios.campaign.register_trial import longest_pass_gap, run_register_trial
from scenarios.campaign.simscan import ScanErrors, simulate_scan
from scenarios.results.json_converter import unstructure

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
    config = register_base("skull")
    noise = config["cell"]["noise"]
    noise["laser_sigma_m"] = noise["model_deformation_rms_m"] = noise["model_noise_rms_m"] = 0.0
    config["register_trial"]["arm"] = {
        "pass_sigma_m": 0.0, "pass_rotation_sigma_rad": 0.0, "jitter_sigma_m": 0.0
    }  # fmt: skip
    config["register_trial"]["scan"]["points"] = 1500
    row = run_register_trial(config, seed=4)
    assert row.verdict == "accepted"
    assert row.target_error_max_m < 5e-5  # facets of the scanned surface only
    assert row.rotation_error_rad < 1e-3
    assert not row.false_accept and row.good
    assert len(row.targets) == 4 and row.n_points == 1500


def test_scan_faults_in_a_registration_trial():
    """A dropout burst (30 % of one pass's sweep) leaves a gap the trial sees; a shiny patch's
    returns (10 mm too long) lie off the matched model; both are left out and the match is
    accepted within the goal. Ground truth: the simulated scan (what was lost, what is
    spurious) and the trial's evaluator (the true pose)."""

    for name in ("laser_dropout_burst", "laser_spurious"):
        config = register_base("skull")
        config["faults"] = {name: True}
        row = run_register_trial(config, 0)
        assert row.faults == (ScanFaultOutcome(name, "recovered", "register"),)
        assert row.verdict == "accepted" and row.target_error_max_m < 1e-3
        assert not row.harmed


def test_the_row_has_the_tables_columns_in_order():
    """The row flattens to the results table's columns as the store and the report read them
    (the names and order of results.csv)."""
    config = register_base("housing")
    config["register_trial"]["scan"].update(points=400, samples=20_000)
    config["faults"] = "laser_dropout_burst,laser_spurious"
    row = run_register_trial(config, 1)
    columns = unstructure(row)
    targets = [f"{c}{k}{s}" for k in range(len(row.targets))
               for c, s in (("err_t", "_m"), ("tre_t", "_m"), ("ratio_t", ""))]  # fmt: skip
    assert list(columns) == [
        "case", "model", "scanned_model", "n_points", "surface_fraction", "outlier_fraction",
        "verdict", "reason", "accepted", "ambiguity", "rms_m", "inlier_fraction",
        "worst_predicted_tre_m", "rotation_error_rad", "centroid_error_m", "target_error_max_m",
        "target_error_mean_m", "target_error_real_max_m", "predicted_tre_max_m", "right_object",
        "good", "false_accept", "n_targets", "targets", *targets,
        "fault.laser_dropout_burst", "fault.laser_dropout_burst.stage", "fault.laser_spurious",
        "fault.laser_spurious.stage", "harmed", "match_seconds", "trial_seconds",
    ]  # fmt: skip
    assert columns["n_targets"] == len(row.targets) > 0
    assert columns["targets"] == ";".join(t.name for t in row.targets)
    assert columns["err_t0_m"] == row.targets[0].error_m
    assert columns["accepted"] in (0, 1) and columns["accepted"] == int(row.accepted)
    assert (columns["model"], columns["scanned_model"]) == ("housing", "housing")


def test_the_trial_reads_the_jobs_sections():
    """The job's keys reach the trial: its scan faults' amounts in the simulated scan's terms
    (a burst's seconds at 0.3 of a pass a second; the cell's defaults without an amount),
    the trial's own section filled in where the job has none."""
    config = register_base("skull")
    del config["register_trial"]
    setup = parse_register_job(config)
    assert setup.trial.scan.points == 3000 and setup.job.register_trial == setup.trial
    assert setup.faults == ScanFaultAmounts()
    config["faults"] = {"laser_dropout_burst": True, "laser_spurious": {"amount": 0.005}}
    assert parse_register_job(config).faults == ScanFaultAmounts(0.3, 0.005)
    config["faults"] = {"laser_dropout_burst": 0.5}
    assert parse_register_job(config).faults == ScanFaultAmounts(dropout_burst=0.15)
    assert parse_register_job(config).faults.names == ("laser_dropout_burst",)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("laser", {"sigma": 1e-4}, "unknown key 'laser'"),
        ("stage", "register", "unknown key 'stage'"),
        ("faults", {"laser_dropout_burst": {"stage": "execute"}}, "during its scan"),
        ("faults", {"laser_dropout_burst": 0.0}, "longer than 0 s"),
        ("register_trial", {"scan": {"cell_m": 0.0}}, "register_trial.scan.cell_m"),
        ("register_trial", {"arm": {"pass_sigma": 3e-4}}, "unknown key 'register_trial.arm"),
    ],
)
def test_a_bad_trial_configuration_is_named(key, value, message):
    config = register_base("skull")
    config[key] = value
    with pytest.raises(CampaignError, match=message) as info:
        parse_register_job(config, "mine.yaml")
    assert str(info.value).startswith("mine.yaml: ")


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
