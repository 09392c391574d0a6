"""The full stage: one headless skull scenario run as a campaign trial (short scan)."""

from __future__ import annotations

from pathlib import Path

from models import builtin_model
from scenarios.campaign import plan_campaign, run_campaign

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
