"""The verification before the first touch (scenarios.offline.verification): its decisions, the
allowance taken from the goal, its report in results.json and the recording, and the
operating curve of a campaign's rows (scenarios.campaign.operating_curve).

Ground truth: the decision rules are checked on hand-made checks; the short skull run (no
fault, tests/conftest.py) moved nothing, so every target must agree; the operating curve is
checked on hand-made rows whose counts are known.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from rrd_reader import read_rrd

from scenarios.campaign.operating_curve import operating_curve
from scenarios.offline.settings import VerifySection
from scenarios.offline.verification import allowances
from scenarios.results.json_converter import structure, unstructure
from scenarios.results.verification_result import TargetCheck, Verification

GOAL_M = 0.5e-3


def _check(moved: float, bound: float, allowance: float = 0.2e-3, apart: float = 0.0):
    return TargetCheck("t", moved, bound, allowance, apart, 1.2e-3, GOAL_M)


def test_a_move_beyond_the_allowance_is_detected():
    assert _check(0.25e-3, 0.1e-3).decision == "moved"
    assert _check(0.15e-3, 0.1e-3).decision == "agrees"
    # Beyond an allowance smaller than the bound, but within the bound: not called a move.
    assert _check(0.09e-3, 0.1e-3, allowance=0.07e-3).decision == "unresolved"
    assert _check(0.12e-3, 0.1e-3, allowance=0.07e-3).decision == "moved"
    # The second scan's own match far from the registration: a wrong scan.
    assert _check(0.05e-3, 0.1e-3, apart=1.5e-3).decision == "inconsistent"


def test_a_check_is_resolved_only_if_it_tells_the_allowance_from_none_and_sees_the_goal():
    """Resolved: the bound within the allowance, and allowance + bound within the goal."""
    assert _check(0.0, 0.10e-3, allowance=0.2e-3).resolved
    assert not _check(0.0, 0.25e-3, allowance=0.2e-3).resolved  # bound beyond the allowance
    assert not _check(0.0, 0.15e-3, allowance=0.4e-3).resolved  # 0.55 mm: beyond the goal
    assert not _check(0.0, 0.01e-3, allowance=-0.1e-3).resolved  # the goal already spent
    unresolved = Verification(("pass 1",), 5000, 7.0, (_check(0.0, 0.25e-3),))
    assert unresolved.agrees and not unresolved.resolved
    assert unresolved.verified_to_m == pytest.approx(0.45e-3)
    assert "verified to 0.45 mm only" in unresolved.summary()


def test_the_allowance_is_the_goal_less_the_error_already_there():
    tre = np.array([0.27e-3, 0.0])
    got = allowances(GOAL_M, tre, 0.15e-3)
    assert got == pytest.approx([GOAL_M - math.hypot(0.27e-3, 0.15e-3), GOAL_M - 0.15e-3])
    assert allowances(None, tre, 0.0) == pytest.approx(3 * tre)


def test_the_report_reads_back_as_written():
    v = Verification(("pass 3", "pass 1"), 30000, 14.5, (_check(0.3e-3, 0.1e-3),))
    back = structure(json.loads(json.dumps(unstructure(v))), Verification)
    assert back == v and unstructure(back)["targets"][0]["decision"] == "moved"


@pytest.fixture(scope="module")
def results(short_skull_run: Path) -> dict:
    return json.loads((short_skull_run / "results.json").read_text())


def test_a_run_reports_its_verification_per_target(results: dict) -> None:
    """No fault moved the phantom: one verification, every target agrees within what the
    goal allows, resolved (its bound within the allowance), the allowance the goal less the
    registration's predicted TRE and the arm's accuracy; its scan took cell time."""
    (v,) = results["verifications"]
    tre = {t["name"]: t["predicted_tre_m"] for t in results["targets"]}
    arm = VerifySection().arm_accuracy_m
    assert v["agrees"] and v["resolved"] and 0.0 < v["scan_time_s"] < 30.0
    assert {t["name"] for t in v["targets"]} == set(tre)
    for t in v["targets"]:
        assert t["decision"] == "agrees"
        assert t["allowance_m"] == pytest.approx(GOAL_M - math.hypot(tre[t["name"]], arm))
        assert 0.0 < t["uncertainty_m"] <= t["allowance_m"]
        # The phantom did not move: what is measured is the check's own noise.
        assert t["moved_m"] <= t["uncertainty_m"]
    assert v["verified_to_m"] <= GOAL_M


def test_the_recording_shows_the_verification(short_skull_run: Path, results: dict) -> None:
    """The targets of the verification, labelled with its decision, and its bar charts."""
    e = read_rrd(short_skull_run / "run.rrd")
    targets = e["/world/cell/table/frame/verify/targets"]
    (_, labels), *_ = targets.timed("Points3D:labels")
    assert len(labels) == len(results["verifications"][0]["targets"])
    assert all(label.endswith(": agrees") for label in labels)
    assert "/plots/verify/moved_mm" in e and "/plots/verify/allowance_mm" in e


def _row(
    amount: float, outcome: str, move: float, rms: float, trial: int = 0, run: str = "complete"
):
    return {
        "trial": str(trial),
        "vary.faults.object_bump": str(amount),
        "status": "ok",
        "run_status": run,
        "job_rms_m": str(rms),
        "fault.object_bump": outcome,
        "fault.object_bump.target_move_m": str(move),
        "verify_scan_time_s": "7.0",
    }


def test_the_operating_curve_counts_what_its_rows_hold():
    rows = [
        _row(0.0, "missed", 0.0, 0.3e-3, trial=0),
        _row(0.0, "recovered", 0.0, 0.55e-3, trial=1),  # a false alarm; the goal missed
        _row(0.0002, "missed", 0.3e-3, 0.6e-3, trial=0),  # unseen, the goal missed by it
        _row(0.0002, "missed", 0.45e-3, 0.6e-3, trial=1),  # missed without the bump too
        _row(0.0005, "recovered", 0.8e-3, 0.3e-3, trial=0),
        _row(0.0005, "missed", 0.7e-3, 0.4e-3, trial=1),  # beyond the goal and unseen
        _row(0.0005, "missed", 0.7e-3, 0.6e-3, trial=2, run="at_risk"),  # said, not complete
    ]
    curve = operating_curve(rows, "object_bump", GOAL_M)
    assert [p.amount_m for p in curve.points] == [0.0, 0.0002, 0.0005]
    assert [p.detected for p in curve.points] == [1, 0, 1]
    assert curve.false_alarm_rate == 0.5
    assert curve.beyond_goal_rate == pytest.approx(1 / 3)  # 3 beyond the goal, 1 detected
    assert [p.rms_missed for p in curve.points] == [1, 2, 0]  # an at-risk run is not complete
    assert [p.at_risk for p in curve.points] == [0, 0, 1]
    assert curve.rms_missed_unseen == 1  # trial 1 missed the goal without the bump
    assert len(curve.meets()) == 3
    assert curve.table()[2].startswith("| 0 | 2 | 1 (50%) | 0 (0) | 1 (0) | 0 | 0.43 | 7.0 |")
    with pytest.raises(ValueError, match=r"vary\.faults\.table_stall"):
        operating_curve(rows, "table_stall", GOAL_M)
