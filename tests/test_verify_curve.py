"""The operating curves of the checks after the scan (bench/verify_curve.py): docs/benchmarks.md's
tables are what the committed campaign rows give, those rows meet the detection goals, and
(slow tier) a smaller campaign run here meets them too.

Ground truth: the campaign rows' outcomes come from the simulated cell's fault injector
and the evaluator (how far a bump moved the farthest target; the achieved target errors),
never from the checks under test.
"""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from bench_support.readme_table_rows import readme_table

from scenarios.campaign import plan_campaign, run_campaign
from scenarios.campaign.operating_curve import operating_curve
from scenarios.results.run import RAN

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "bench" / "data"
GOAL_M = 0.5e-3
#: The curves in docs/benchmarks.md, by the name they are kept under (verify_FAULT[.CELL]).
CURVES = (
    "object_bump",
    "tool_lock_fail",
    "table_stall",
    "tool_lock_fail.builtin",
    "tool_lock_fail.ur5",
)


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("name", CURVES)
def test_the_readme_curve_is_its_campaign_s(name: str) -> None:
    fault = name.partition(".")[0]
    curve = operating_curve(_rows(DATA / f"verify_{name}.csv"), fault, GOAL_M)
    readme = (ROOT / "docs" / "benchmarks.md").read_text()
    assert readme_table(readme, f"verify_{name}") == curve.table()[2:]
    assert (DATA / f"verify_{name}.png").is_file()


#: Of the seat campaign's runs, those that end `complete` with the RMS goal missed, at most:
#: on the built-in arm seed 95014 (0.1 mm off, within the check's tolerance: its RMS 0.518 mm
#: against the budget's bound 0.423 mm, the budget's shortfall that docs/benchmarks.md names).
SEAT_MISSED = {"builtin": 1, "ur5": 0}


@pytest.mark.parametrize("cell", ["builtin", "ur5"])
def test_no_seat_fault_passes_under_the_checks(cell: str) -> None:
    """The screwer seated 0.1-0.4 mm off, at least 20 runs per amount, on the built-in arm
    and in the UR5 cell: every seat 0.3 mm or more off is called off by the TCP check, and
    no run ends `complete` with its RMS goal missed (against the true targets) beyond the
    one the docs name, whether or not the check saw the seat (the runs it does not stop
    carry the reading in their error budget, which says when the goal is at risk); every
    trial ran (no crash, no refusal)."""
    rows = _rows(DATA / f"verify_tool_lock_fail.{cell}.csv")
    curve = operating_curve(rows, "tool_lock_fail", GOAL_M)
    amounts = [round(p.amount_m * 1e3, 3) for p in curve.points]
    assert amounts == [0.1, 0.2, 0.3, 0.4], amounts
    assert min(p.trials for p in curve.points) >= 20
    assert all(p.detected == p.trials for p in curve.points if p.amount_m >= 0.3e-3)
    assert all(r["status"] == "ok" and r["run_status"] in RAN for r in rows)
    assert sum(p.rms_missed for p in curve.points) <= SEAT_MISSED[cell], curve.table()


def test_the_bump_curve_meets_the_detection_goals() -> None:
    """At least 30 runs per amount; 95 % of the bumps that moved a target beyond the RMS
    goal detected, at most 5 % false alarms at 0, no complete run with its RMS goal missed
    while a bump went unseen."""
    curve = operating_curve(_rows(DATA / "verify_object_bump.csv"), "object_bump", GOAL_M)
    assert min(p.trials for p in curve.points) >= 30
    assert curve.points[0].amount_m == 0.0
    assert curve.meets() == []


SHORT = "name: skull\nlocalization:\n  scan: {speed_m_s: 0.25, period_s: 0.02}\n"


@pytest.mark.slow
def test_a_small_bump_campaign_meets_the_detection_goals(tmp_path: Path) -> None:
    """No bump and a 0.5 mm bump (turned 0.5 deg), two runs each: no false alarm, every
    bump that moved a target beyond the goal detected, no run complete with its RMS goal
    missed while the bump went unseen."""
    config = tmp_path / "short.yaml"
    config.write_text(SHORT)
    spec = plan_campaign(
        str(config), stage="full", trials=2, seed=95000, vary=["faults.object_bump=0,0.0005"]
    )
    outcome = run_campaign(spec, tmp_path / "campaign", progress=False)
    rows = [{k: "" if v is None else str(v) for k, v in r.items()} for r in outcome.rows]
    assert all(r["status"] == "ok" for r in rows), [r["error"] for r in rows]
    curve = operating_curve(rows, "object_bump", GOAL_M)
    assert [p.trials for p in curve.points] == [2, 2]
    assert curve.points[1].beyond_goal == 2  # the truth: both bumps moved a target > 0.5 mm
    assert curve.meets(detect=1.0, false_alarms=0.0) == []
