"""The Dask backend on a local cluster of 2 worker processes: the same trials give the same
rows as when they run in this process (timings aside)."""

from __future__ import annotations

from pathlib import Path

from scenarios.campaign import campaign_trials, plan_campaign, run_campaign, run_trial

TIMING = ("match_seconds", "trial_seconds")


def test_dask_local_cluster_runs_the_campaign(tmp_path: Path) -> None:
    config = tmp_path / "cheap.yaml"
    config.write_text("model: housing\nscan:\n  points: 400\n  samples: 20000\n")
    spec = plan_campaign(str(config), trials=2, vary=["laser.sigma=1e-4,3e-4"])
    outcome = run_campaign(spec, tmp_path / "campaign", backend="dask", workers=2, progress=False)
    assert (outcome.ran, outcome.skipped) == (4, 0)
    assert (tmp_path / "campaign" / "report.md").is_file()
    by_id = {r["trial_id"]: r for r in outcome.rows}
    assert len(by_id) == 4
    for trial in campaign_trials(spec)[::3]:  # the first and the last, recomputed here
        here = run_trial(trial)
        there = by_id[trial.trial_id]
        assert here["status"] == there["status"] == "ok"
        assert {k: v for k, v in here.items() if k not in TIMING} == {
            k: v for k, v in there.items() if k not in TIMING
        }
