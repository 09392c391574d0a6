"""The full stage: one headless skull scenario run as a campaign trial (short scan)."""

from __future__ import annotations

from pathlib import Path

import pytest

from models.registry import builtin_model
from scenarios.campaign import plan_campaign, run_campaign

#: A short skull job a trial, three in all.
pytestmark = pytest.mark.slow

SHORT = "name: skull\nlocalization:\n  scan: {speed_m_s: 0.25, period_s: 0.02}\n"


def test_one_full_skull_trial(tmp_path: Path) -> None:
    config = tmp_path / "short.yaml"
    config.write_text(SHORT)
    spec = plan_campaign(str(config), stage="full", trials=1, seed=3)
    assert spec.base_config["output"] == {"rrd": False, "plots": False}  # headless
    outcome = run_campaign(spec, tmp_path / "campaign", progress=False)
    (row,) = outcome.rows
    assert row["status"] == "ok", row.get("error")
    assert row["seed"] == 3 and row["job"] == "skull"
    holes = builtin_model("skull", 0).burr_holes
    assert row["targets"].split(";") == [h.name for h in holes]
    # The scenario's own evaluator (the truth of the simulated cell): an accepted match and
    # every touched burr hole within the skull job's 1 mm goal.
    assert row["run_status"] == "complete" and row["verdict"] == "accepted"
    assert 0 < row["executed_error_max_m"] < 1.0e-3
    assert 0 < row["target_error_max_m"] < 1.0e-3
    assert row["false_accept"] == 0 and row["good"] == 1
    assert all(row[f"tre_t{k}_m"] > 0 for k in range(len(holes)))
    report = (tmp_path / "campaign" / "report.md").read_text()
    assert "Stage: full" in report and "register only" not in report
    assert not list((tmp_path / "campaign").rglob("*.rrd"))


def test_a_fault_campaign_reports_each_fault(tmp_path: Path) -> None:
    """`--vary faults=NAME,...`: each trial injects one fault; the rows carry its outcome and
    the stage that detected it, and the report counts them per fault. Ground truth: the
    cell's injector (what fired) and the evaluator (the target errors)."""
    config = tmp_path / "short.yaml"
    config.write_text(SHORT)  # calibrated, as shipped: a recovered run meets the 1 mm goal
    spec = plan_campaign(
        str(config), stage="full", trials=1, seed=3, vary=["faults=object_bump,payload"]
    )
    outcome = run_campaign(spec, tmp_path / "campaign", progress=False)
    rows = {r["vary.faults"]: r for r in outcome.rows}
    assert set(rows) == {"object_bump", "payload"}
    bump, payload = rows["object_bump"], rows["payload"]
    assert bump["fault.object_bump"] == "recovered" and bump["fault.object_bump.stage"] == "verify"
    assert bump["run_status"] == "complete" and bump["harmed"] == 0
    assert payload["fault.payload"] == "stopped" and payload["run_status"] == "aborted"
    assert payload["stage"] == "execute" and payload["harmed"] == 0
    report = (tmp_path / "campaign" / "report.md").read_text()
    assert "- complete runs with a target error beyond 1 mm: 0 (goal 0)" in report
    assert "| object_bump | 1 | 1 (verify 1) | 1 | 0 | 0 | 0 | 0 |" in report
    assert "| payload | 1 | 1 (execute 1) | 0 | 1 | 0 | 0 | 0 |" in report
