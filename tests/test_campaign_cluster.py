"""The Dask backend on a local cluster of 2 worker processes: the same trials give the same
rows as when they run in this process (timings aside), and a worker killed mid-trial costs
no row and counts none twice."""

from __future__ import annotations

import os
import signal
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from dask.distributed import Client, LocalCluster, get_task_stream

from scenarios.campaign import campaign_trials, plan_campaign, run_campaign, run_trial
from scenarios.campaign.store import read_csv

#: Each test starts a local Dask cluster of two worker processes.
pytestmark = pytest.mark.slow

TIMING = ("match_seconds", "trial_seconds")


def test_dask_local_cluster_runs_the_campaign(tmp_path: Path) -> None:
    config = tmp_path / "cheap.yaml"
    config.write_text(
        "cell: {object: {model: housing}}\n"
        "register_trial:\n  scan:\n    points: 400\n    samples: 20000\n"
    )
    spec = plan_campaign(str(config), trials=2, vary=["cell.noise.laser_sigma_m=1e-4,3e-4"])
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


def _executing(dask_worker: Any) -> list[str]:
    """The keys a worker is running now (run on each worker by `client.run`)."""
    return [str(ts.key) for ts in dask_worker.state.executing]


def _trial_of(key: str) -> str:
    """The trial id of a task key "trial-<trial id>-<token>"."""
    return key.removeprefix("trial-").rsplit("-", 1)[0]


def _holders(dask_scheduler: Any, prefix: str) -> list[str]:
    """The workers holding the result of the task whose key starts with `prefix`."""
    return [
        ws.address
        for key, ts in dask_scheduler.tasks.items()
        if str(key).startswith(prefix)
        for ws in ts.who_has
    ]


def test_a_dask_worker_killed_mid_trial_loses_no_row_and_counts_none_twice(
    tmp_path: Path,
) -> None:
    config = tmp_path / "cheap.yaml"
    config.write_text(
        "cell: {object: {model: housing}}\n"
        "register_trial:\n  scan:\n    points: 400\n    samples: 20000\n"
    )
    spec = plan_campaign(str(config), trials=12)
    out = tmp_path / "campaign"
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        collected: list[str] = []
        killed: dict[str, Any] = {}

        def kill_a_worker_mid_trial(row: dict[str, Any]) -> None:
            """After the third row: SIGKILL a worker that is running a trial and holds no
            row not yet collected (the row in hand is released once stored)."""
            collected.append(row["trial_id"])
            if killed or len(collected) < 3:
                return
            holding = client.run_on_scheduler(_holders, prefix=f"trial-{row['trial_id']}-")
            running = client.run(_executing)
            victims = [w for w, keys in running.items() if keys and w not in holding]
            if victims:
                pids = client.run(os.getpid, workers=victims[:1])
                killed.update(worker=victims[0], trial=running[victims[0]][0])
                killed["before"] = list(collected)
                os.kill(pids[victims[0]], signal.SIGKILL)

        with get_task_stream(client) as stream:
            outcome = run_campaign(
                spec,
                out,
                backend="dask",
                scheduler=cluster.scheduler_address,
                progress=False,
                on_row=kill_a_worker_mid_trial,
            )
        assert killed, "no worker was killed mid-trial"
        assert killed["worker"] not in client.run(os.getpid)  # it died; Dask restarted one

    ids = [r["trial_id"] for r in read_csv(out / "results.csv")]
    expected = [t.trial_id for t in campaign_trials(spec)]
    assert sorted(ids) == expected  # each trial exactly once
    assert sorted(collected) == expected  # each row handed over once
    assert (outcome.ran, outcome.skipped) == (12, 0)
    assert all(r["status"] == "ok" for r in outcome.rows)
    assert _trial_of(killed["trial"]) not in killed["before"]  # it ran again elsewhere
    # No trial collected before the kill ran twice (its row was not left on the worker).
    runs = Counter(_trial_of(d["key"]) for d in stream.data)
    assert all(runs[i] == 1 for i in killed["before"]), runs
    # Rerun into the same folder: nothing left to run, the table unchanged.
    again = run_campaign(spec, out, workers=1, progress=False)
    assert (again.ran, again.skipped) == (0, 12)
    assert [r["trial_id"] for r in read_csv(out / "results.csv")] == ids
