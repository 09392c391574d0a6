"""The pytest plugin's assertions on a real run's result (the short skull run), changed where
a test needs a failure: each failure names the target or goal, the numbers, the seed and the
run folder."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from scenarios.results.events import FaultOutcome, Injection
from scenarios.results.exported_result import ExportedRun
from scenarios.results.results_file import read_results
from scenarios.results.run import GoalCheck
from scenarios.testing import JobRun, assert_detected, assert_goals, assert_targets_within


@pytest.fixture
def run(short_skull_run: Path) -> JobRun:
    return JobRun(read_results(short_skull_run), short_skull_run)


def test_a_run_within_its_goals_passes(run: JobRun) -> None:
    assert run.result.status == "complete"
    assert_goals(run)
    worst = max(t.error_m for t in run.result.targets)
    assert_targets_within(run, worst + 1e-6)
    assert_targets_within(run, worst + 1e-6, targets=[run.result.targets[0].name])


def test_targets_beyond_the_tolerance_are_named(run: JobRun) -> None:
    errors = {t.name: t.error_m for t in run.result.targets}
    tolerance = sorted(errors.values())[-2]  # the worst target alone is beyond it
    with pytest.raises(AssertionError) as failed:
        assert_targets_within(run, tolerance)
    text = str(failed.value)
    worst = max(errors, key=errors.__getitem__)
    assert f"seed {run.seed}" in text and "1 of" in text
    assert f"{worst}: {errors[worst] * 1e3:.3f} mm > {tolerance * 1e3:.3f} mm" in text
    assert f"run folder {run.folder}" in text and "rerun " in text
    with pytest.raises(AssertionError, match="no target nosuch"):
        assert_targets_within(run, 1.0, targets=["nosuch"])


def test_a_missed_goal_and_an_unfinished_run_fail(run: JobRun) -> None:
    checks = dict(run.result.checks)
    checks["target_error_rms_m"] = GoalCheck(1e-5, False)
    missed = JobRun(replace(run.result, checks=checks), run.folder)
    with pytest.raises(AssertionError) as failed:
        assert_goals(missed)
    rms = run.result.target_error_rms_m
    assert rms is not None
    assert f"target_error_rms_m: {rms * 1e3:.3f} mm > goal 0.010 mm" in str(failed.value)
    refused = JobRun(
        replace(run.result, status="refused", stage="check", reason="too far"), run.folder
    )
    for check in (assert_goals, lambda r: assert_targets_within(r, 1.0)):
        with pytest.raises(AssertionError, match=re.escape("ended refused in check\n  too far")):
            check(refused)


def test_an_exported_program_stopped_on_the_cell_fails_the_goals(run: JobRun) -> None:
    """The job met its goals, but the program it exported was stopped by the supervision
    when the job ran it on the real cell: the goals are not met."""
    assert run.result.exported_program is not None
    assert run.result.exported_program.status == "complete"
    stopped = ExportedRun(
        "aborted", "motion supervision stopped the arm (collision: 75 N on link4)"
    )
    aborted = JobRun(replace(run.result, exported_program=stopped), run.folder)
    with pytest.raises(AssertionError) as failed:
        assert_goals(aborted)
    text = str(failed.value)
    assert f"the exported program {run.result.program_file} ended aborted" in text
    assert "75 N on link4" in text and f"seed {run.seed}" in text


def test_a_fault_detected_or_missed(run: JobRun) -> None:
    bump = FaultOutcome(
        "object_bump", 0.002, "verify", None, Injection("verify", 40.0, "moved"), "verify"
    )
    assert_detected(JobRun(replace(run.result, faults=(bump,)), run.folder), "object_bump")
    missed = replace(bump, detected_by="missed")
    with pytest.raises(AssertionError, match="object_bump went undetected"):
        assert_detected(JobRun(replace(run.result, faults=(missed,)), run.folder), "object_bump")
    with pytest.raises(AssertionError, match="no fault object_bump in the run"):
        assert_detected(run, "object_bump")


#: `twincell run examples/my_cell/job.yaml --cell examples/my_cell/cell.yaml --seed 3 --set
#: export.compensation=nominal` (no recording, no plots): the job's own execution met the goals
#: (RMS 0.394 mm, max 0.473 mm against 0.5 and 1.0 mm); the user's module it exported, run by
#: a controller without absolute accuracy (compensation nominal: only the work object
#: corrected), did not (RMS 0.539 mm, max 0.705 mm; filtered, the default, 0.392 mm).
MY_CELL_SEED3 = Path(__file__).parent / "data" / "results" / "my_cell_seed3.json"


def test_an_exported_program_that_missed_a_goal_fails_the_goals() -> None:
    """The figures as that run measured them (ground truth: its results.json, not made here);
    the same run with the exported figures edited within the goals passes, and edited beyond
    the largest-error goal alone names that goal alone."""
    run = JobRun(read_results(MY_CELL_SEED3), MY_CELL_SEED3.parent)
    r, exported = run.result, run.result.exported_program
    assert exported is not None and exported.compensation == "nominal"
    assert all(check.met for check in r.checks.values())
    with pytest.raises(AssertionError) as failed:
        assert_goals(run)
    text = str(failed.value)
    assert "job my_phantom, seed 3: the exported program program.mod (nominal" in text
    assert "exported program RMS: 0.539 mm > goal target_error_rms_m 0.500 mm" in text
    assert "exported program max" not in text  # 0.705 mm is within the 1 mm goal
    assert "pTouch0: 0.705 mm" in text
    assert "the job's own execution met them: RMS 0.394 mm, max 0.473 mm" in text

    def edited(rms_m: float, max_m: float) -> JobRun:
        figures = replace(exported, target_error_rms_m=rms_m, target_error_max_m=max_m)
        return JobRun(replace(r, exported_program=figures), run.folder)

    assert_goals(edited(0.499e-3, 0.999e-3))  # within both goals by 1 um
    with pytest.raises(AssertionError) as failed:
        assert_goals(edited(0.45e-3, 1.2e-3))
    text = str(failed.value)
    assert "exported program max: 1.200 mm > goal target_error_max_m 1.000 mm" in text
    assert "exported program RMS" not in text
