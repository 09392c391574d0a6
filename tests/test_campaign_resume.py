"""A campaign killed mid-way and restarted: the finished trials are kept as they were, the
others run, and the table holds exactly one row per trial."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from scenarios.campaign import plan_campaign, run_campaign

TRIALS = 10
#: A campaign in a process of its own, killed, then run to its end.
pytestmark = pytest.mark.slow


def test_kill_and_restart_gives_exactly_one_row_per_trial(tmp_path: Path) -> None:
    config = tmp_path / "cheap.yaml"
    config.write_text(
        "cell: {object: {model: housing}}\n"
        "register_trial:\n  scan:\n    points: 400\n    samples: 20000\n"
    )
    out = tmp_path / "campaign"
    command = [sys.executable, "-m", "scenarios.cli.app", "campaign", str(config), "--trials",
               str(TRIALS), "--out", str(out), "--quiet"]  # fmt: skip
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    trials = out / "trials"
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and len(list(trials.glob("*.json"))) < 3:
        assert process.poll() is None, process.stderr.read().decode() if process.stderr else ""
        time.sleep(0.05)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    if process.stderr is not None:
        process.stderr.close()
    before = {p.name: p.read_bytes() for p in trials.glob("*.json")}
    assert 3 <= len(before) < TRIALS  # killed mid-way

    spec = plan_campaign(str(config), trials=TRIALS)
    outcome = run_campaign(spec, out, workers=1, progress=False)
    assert outcome.ran == TRIALS - len(before) and outcome.skipped == len(before)
    with open(out / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ids = [r["trial_id"] for r in rows]
    assert len(rows) == TRIALS and len(set(ids)) == TRIALS
    assert sorted(int(r["seed"]) for r in rows) == list(range(TRIALS))
    after = {p.name: p.read_bytes() for p in trials.glob("*.json")}
    assert all(after[name] == data for name, data in before.items())  # kept as they were
    assert not [
        p for p in trials.iterdir() if not p.name.endswith(".json") and not p.name.startswith(".")
    ]
