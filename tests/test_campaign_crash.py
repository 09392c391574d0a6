"""A campaign keeps crashes apart from failures: a trial stopped by a user error is a failed
row as before; one stopped by any other exception (a bug) is a crashed row, its traceback in
the trial's folder, counted apart by the report, and `twincell campaign` exits 5. The trial
function here is a stand-in registered in STAGES, so that each trial costs nothing; the
exception each seed raises is the ground truth."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from dask.distributed import LocalCluster

from registration.registration_errors import InputError
from scenarios.campaign import STAGES, plan_campaign, run_campaign
from scenarios.campaign.store import read_csv
from scenarios.cli.app import main

CRASH_EXIT = 5
"""`twincell campaign`'s exit status when a trial crashed (docs/reference/statuses.md)."""


@dataclass(frozen=True)
class _Row:
    verdict: str
    accepted: int
    value: float


def refuse_odd_seeds(config: dict[str, Any], seed: int) -> _Row:
    """Seed 0 returns a row; seed 1 meets input it cannot use (a user error)."""
    if seed % 2:
        raise InputError("scan has 2 points; a registration needs at least 3")
    return _Row("accepted", 1, float(seed))


def crash_on_odd_seeds(config: dict[str, Any], seed: int) -> _Row:
    """Seed 0 returns a row; seed 1 has a bug (a missing key)."""
    if seed % 2:
        return _Row("accepted", 1, {"seed": seed}["no_such_key"])
    return _Row("accepted", 1, float(seed))


@pytest.fixture
def stage(monkeypatch: pytest.MonkeyPatch):
    """Make the register stage's trial function the named one of this module."""

    def use(function: str) -> None:
        monkeypatch.setitem(STAGES, "register", f"{__name__}:{function}")

    return use


def _report_totals(folder: Path) -> dict[str, Any]:
    return json.loads((folder / "report.json").read_text())["groups"][-1]


def test_a_user_error_stays_a_failed_row_and_the_command_exits_0(
    tmp_path: Path, stage, capsys: pytest.CaptureFixture[str]
) -> None:
    stage("refuse_odd_seeds")
    out = tmp_path / "campaign"
    assert main(["campaign", "skull", "--trials", "2", "--out", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "crashed" not in captured.err
    rows = {r["seed"]: r for r in read_csv(out / "results.csv")}
    assert (rows["0"]["status"], rows["1"]["status"]) == ("ok", "error")
    assert rows["1"]["error"].startswith("InputError: scan has 2 points")
    assert "traceback" not in rows["1"]
    assert not [p for p in (out / "trials").iterdir() if p.is_dir()]  # no trial folder
    totals = _report_totals(out)
    assert (totals["trials"], totals["errors"], totals["crashes"]) == (2, 1, 0)
    assert "- trials: 2 (1 failed, 0 crashed)" in (out / "report.md").read_text()


def test_a_program_error_is_a_crash_with_its_traceback_and_exit_5(
    tmp_path: Path, stage, capsys: pytest.CaptureFixture[str]
) -> None:
    stage("crash_on_odd_seeds")
    out = tmp_path / "campaign"
    code = main(["campaign", "skull", "--trials", "2", "--out", str(out), "--quiet"])
    assert code == CRASH_EXIT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "1 of 2 trials crashed" in err[0]
    assert f"{out / 'trials'}/<trial_id>/traceback.txt" in err[0]
    _assert_one_crash(out)


def test_the_dask_backend_records_a_crash_the_same_way(tmp_path: Path, stage) -> None:
    """The Dask path on an in-process cluster (its worker sees this module's stand-in)."""
    stage("crash_on_odd_seeds")
    out = tmp_path / "campaign"
    spec = plan_campaign("skull", trials=2)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        outcome = run_campaign(
            spec, out, backend="dask", scheduler=cluster.scheduler_address, progress=False
        )
    assert [r["seed"] for r in outcome.crashed] == [1]
    _assert_one_crash(out)


def _assert_one_crash(out: Path) -> None:
    """Seed 0's trial returned its row; seed 1's crashed on the missing key."""
    rows = {r["seed"]: r for r in read_csv(out / "results.csv")}
    assert (rows["0"]["status"], rows["1"]["status"]) == ("ok", "crash")
    assert rows["1"]["error"].startswith("KeyError: 'no_such_key' (test_campaign_crash.py:")
    assert rows["0"]["traceback"] == ""
    assert rows["1"]["traceback"] == "trials/p000-t00001/traceback.txt"
    text = (out / rows["1"]["traceback"]).read_text()
    assert text.startswith("Traceback (most recent call last):")
    assert "in crash_on_odd_seeds" in text
    assert text.rstrip().endswith("KeyError: 'no_such_key'")
    assert not (out / "trials" / "p000-t00000").exists()  # only the crash has a folder
    totals = _report_totals(out)
    assert (totals["trials"], totals["errors"], totals["crashes"]) == (2, 0, 1)
    assert "- trials: 2 (0 failed, 1 crashed)" in (out / "report.md").read_text()
