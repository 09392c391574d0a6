"""The error budget of a job's targets: the model's term read from the scan near each target
(against a surface displaced by a known amount), the budget's decision against the goals,
results.json's round trip, and a run whose budget puts its goal out of reach, which ends
"at_risk" (exit status 6) instead of claiming the goal.

Ground truth: the displacement the test gives the points, and the goals and terms the test
states; never the budget's own figures."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from models.mesh import TriangleMesh
from models.model import ObjectModel
from scenarios.offline.error_budget import MIN_LOCAL_POINTS, error_budget, local_model_error
from scenarios.offline.settings import PlanningSettings
from scenarios.results.budget_result import ErrorBudget, TargetBudget
from scenarios.results.calibration_check_result import DriftCheck
from scenarios.results.json_converter import structure, unstructure
from scenarios.results.results_file import read_results


def _plate() -> ObjectModel:
    """A 0.2 m square plate in z = 0 (two triangles), object frame = table frame."""
    v = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])
    mesh = TriangleMesh(v, np.array([[0, 1, 2], [0, 2, 3]]))
    return ObjectModel("plate", mesh, (mesh,))


def test_the_model_term_is_the_scans_distance_from_the_model_near_each_target() -> None:
    rng = np.random.default_rng(3)
    xy = rng.uniform(-0.09, 0.09, size=(20000, 2))
    # The real surface lies 0.3 mm above the model on the left half, on it on the right.
    z = np.where(xy[:, 0] < 0.0, 0.3e-3, 0.0)
    points = np.column_stack([xy, z])
    T_table_object = np.eye(4)
    targets = np.array([[-0.05, 0.0, 0.0], [0.05, 0.0, 0.0], [0.5, 0.5, 0.0]])
    local = local_model_error(_plate(), T_table_object, points, targets)
    assert local[0] == pytest.approx(0.3e-3, abs=1e-9)
    assert local[1] == pytest.approx(0.0, abs=1e-9)
    assert np.isnan(local[2])  # no point within reach: left to the stated tolerance
    # The pose is applied: the same points seen with the object 2 mm along x.
    T_moved = np.eye(4)
    T_moved[0, 3] = 0.002
    moved = local_model_error(_plate(), T_moved, points + np.array([0.002, 0.0, 0.0]), targets)
    np.testing.assert_allclose(moved[:2], local[:2], atol=1e-9)
    few = local_model_error(_plate(), T_table_object, points[: MIN_LOCAL_POINTS // 4], targets)
    assert np.isnan(few).all()


def _settings(goal_rms: float, goal_max: float, tolerance: float) -> PlanningSettings:
    return PlanningSettings(goal_rms_m=goal_rms, goal_max_m=goal_max, model_tolerance_m=tolerance)


def test_the_budget_adds_its_terms_in_quadrature_and_holds_them_to_the_goals() -> None:
    settings = _settings(0.5e-3, 1.0e-3, 0.2e-3)
    arm = settings.verify.arm_accuracy_m
    k_target, k_rms = settings.verify.budget.k_target, settings.verify.budget.k_rms
    names = ("a", "b")
    tre = np.array([0.1e-3, 0.2e-3])
    local = np.array([0.05e-3, np.nan])  # a: below the stated floor; b: not seen
    budget = error_budget(names, tre, local, 0.03e-3, None, settings)
    for target, t in zip(budget.targets, tre, strict=True):
        assert target.model_m == pytest.approx(0.1e-3)  # half the stated tolerance
        sigma = np.sqrt(t**2 + arm**2 + 0.03e-3**2 + 0.1e-3**2)
        assert target.sigma_m == pytest.approx(sigma)
        assert target.bound_m == pytest.approx(k_target * sigma)
    rms_sigma = np.sqrt(np.mean([t.sigma_m**2 for t in budget.targets]))
    assert budget.rms_bound_m == pytest.approx(k_rms * rms_sigma)
    assert budget.within_reach == (k_rms * rms_sigma <= 0.5e-3 and budget.max_bound_m <= 1e-3)

    # A model term seen larger than the stated tolerance, a calibration that fits worse than
    # the arm's budget: both widen the budget.
    wide = error_budget(names, tre, np.array([0.4e-3, 0.4e-3]), 0.03e-3, 0.3e-3, settings)
    assert all(t.model_m == pytest.approx(0.4e-3) for t in wide.targets)
    assert all(t.arm_m == pytest.approx(0.3e-3) for t in wide.targets)
    assert not wide.within_reach
    # A cell that states its own arm figure for the budget (its campaigns' measure).
    own = settings.model_copy(
        update={"verify": settings.verify.model_copy(
            update={"budget": settings.verify.budget.model_copy(update={"arm_m": 0.3e-3})}
        )}
    )  # fmt: skip
    assert error_budget(names, tre, local, 0.0, None, own).targets[0].arm_m == 0.3e-3
    assert wide.risks[0].startswith("the RMS goal 0.500 mm is within reach only to")
    assert "(largest term: model, 0.400 mm)" in wide.risks[0]  # model 0.4 > arm 0.3 > TRE


def test_a_goal_out_of_reach_is_named_with_its_bound_and_largest_term() -> None:
    targets = (
        TargetBudget("near", 0.1e-3, 0.1e-3, 0.0, 0.1e-3, 0.4e-3),
        TargetBudget("far", 0.6e-3, 0.1e-3, 0.0, 0.1e-3, 1.2e-3),
    )
    budget = ErrorBudget(targets, 2.0, 1.0, 0.5e-3, 1.0e-3)
    # RMS bound: sqrt(mean sigma^2) = sqrt((0.03 + 0.38) / 2) mm = 0.453 mm: within 0.5.
    assert budget.rms_bound_m == pytest.approx(np.sqrt((0.03e-6 + 0.38e-6) / 2))
    assert budget.risks == (
        "the largest-error goal 1.000 mm is within reach only to 1.200 mm at far (largest "
        "term: tre, 0.600 mm)",
    )
    assert "largest within 1.200 mm" in budget.summary()
    back = structure(json.loads(json.dumps(unstructure(budget))), ErrorBudget)
    assert back == budget
    unbounded = ErrorBudget((TargetBudget("x", np.inf, 0, 0, 0, np.inf),), 2.0, 1.0, None, 1e-3)
    assert not unbounded.within_reach  # a target no scan constrains is no claim


@pytest.mark.slow
def test_a_run_whose_budget_puts_its_goal_out_of_reach_ends_at_risk(tmp_path: Path) -> None:
    """The model stated to +-3 mm: its term alone (1.5 mm) is beyond the RMS goal, so the
    program runs and the run says the goal is at risk; the same seed with the model stated
    to its default completes."""
    from scenarios.cli.app import main

    code = main(
        ["run", "skull", "--seed", "3", "--out", str(tmp_path), "--quiet", "--no-rrd",
         "--set", "model.tolerance_m=0.003"]
    )  # fmt: skip
    result = read_results(tmp_path / "latest")
    assert code == 6
    assert result.status == "at_risk"
    assert result.reason.startswith("goal at risk: the RMS goal 0.500 mm is within reach only")
    assert result.budget is not None
    assert all(t.model_m >= 1.5e-3 for t in result.budget.targets)
    assert result.targets  # the program ran
    data = json.loads((tmp_path / "latest" / "results.json").read_text())
    assert data["budget"]["within_reach"] is False


def test_the_faults_page_holds_the_kept_campaigns_coverage() -> None:
    """docs/concepts/faults.md's budget table is what bench/budget_coverage.py makes of the
    runs kept in bench/data (their true errors from the evaluator, their budgets made again
    with the code and the settings of now): a changed factor or term changes the table."""
    import importlib.util
    import sys

    root = Path(__file__).resolve().parent.parent
    spec = importlib.util.spec_from_file_location(
        "budget_coverage", root / "bench" / "budget_coverage.py"
    )
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bench  # its dataclasses look their module up
    spec.loader.exec_module(bench)
    rows = bench.kept_rows()
    assert len(rows) == 5
    page = (root / "docs" / "concepts" / "faults.md").read_text()
    for row in rows:
        assert row in page, (
            f"docs/concepts/faults.md: run `python bench/budget_coverage.py --short --page`: {row}"
        )
    # The skull's kept runs: the factors cover 95 % of targets and runs on 60 seeds.
    skull = next(r for r in rows if r.startswith("| skull |"))
    targets, runs = (float(x.strip().rstrip("%")) for x in skull.split("|")[3:5])
    assert targets >= 95.0 and runs >= 95.0


def test_a_kept_calibration_carries_the_drift_its_check_measured() -> None:
    """A calibration kept because its quick check passed carries the spheres' shifts since,
    with the check's own uncertainty: the RMS of the shifts' lengths and three axes of the
    check's sigma, in quadrature (hand-computed here, 1e-15 m); the budget's arm term adds
    it in quadrature to the arm's budget. A check that failed (the cell calibrated anew) or
    has no figure carries nothing."""
    shifts = np.array([[0.03e-3, 0.04e-3, 0.0], [0.0, 0.0, 0.12e-3]])  # 0.05 and 0.12 mm
    check = DriftCheck(shifts, 0.01e-3, 0.12e-3, 0.148e-3, 0.15e-3, True, 18, 900, 1.0)
    expected = np.sqrt((0.05e-3**2 + 0.12e-3**2) / 2 + 3 * 0.01e-3**2)
    assert check.kept_error_m == pytest.approx(expected, abs=1e-15)
    assert replace(check, passed=False).kept_error_m is None
    assert replace(check, sigma_m=None, passed=False).kept_error_m is None
    settings = _settings(0.5e-3, 1.0e-3, 0.2e-3)
    arm = settings.verify.arm_accuracy_m
    names, tre, local = ("a",), np.array([0.1e-3]), np.array([np.nan])
    kept = error_budget(names, tre, local, 0.03e-3, None, settings, check.kept_error_m)
    assert kept.targets[0].arm_m == pytest.approx(np.hypot(arm, expected), abs=1e-15)
    fresh = error_budget(names, tre, local, 0.03e-3, None, settings)
    assert fresh.targets[0].arm_m == arm and kept.rms_bound_m > fresh.rms_bound_m
