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
