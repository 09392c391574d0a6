"""A small campaign end to end on the local backend: a sweep, the folder, resuming without
rerunning, and the report's figures recomputed from results.csv independently."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from scenarios.campaign import CampaignError, plan_campaign, run_campaign
from scenarios.cli.app import main

CHEAP = (
    "cell: {object: {model: housing}}\n"
    "register_trial:\n  scan:\n    points: 400\n    samples: 20000\n"
)


def cheap_config(folder: Path) -> str:
    path = folder / "cheap.yaml"
    path.write_text(CHEAP)
    return str(path)


def read_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_local_campaign_sweep_resume_and_report(tmp_path: Path) -> None:
    config = cheap_config(tmp_path)
    out = tmp_path / "campaign"
    vary = ["register_trial.scan.points=300,500", "register_trial.case=default,outliers"]
    spec = plan_campaign(config, trials=3, vary=vary)
    outcome = run_campaign(spec, out, workers=2, progress=False)
    assert (outcome.ran, outcome.skipped) == (12, 0)

    rows = read_rows(out / "results.csv")
    assert len(rows) == 12 and len({r["trial_id"] for r in rows}) == 12
    assert all(r["status"] == "ok" for r in rows), [r["error"] for r in rows]
    for r in rows:  # the sweep reached each trial's configuration
        assert int(r["n_points"]) == int(r["vary.register_trial.scan.points"])
        assert r["case"] == r["vary.register_trial.case"]
        expected = 0.4 if r["case"] == "outliers" else 0.0
        assert float(r["outlier_fraction"]) == pytest.approx(expected, abs=1.0 / int(r["n_points"]))
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "trials").glob("*.json")}

    # The report's figures, recomputed from the CSV with plain code.
    report = json.loads((out / "report.json").read_text())
    assert report["stage"] == "register"
    assert "register only" in (out / "report.md").read_text()
    groups = {g["label"]: g for g in report["groups"]}
    assert set(groups) == {
        f"register_trial.scan.points={p}, register_trial.case={c}"
        for p in (300, 500)
        for c in ("default", "outliers")
    } | {"all"}
    for label, members in [("all", rows)] + [
        (
            f"register_trial.scan.points={p}, register_trial.case={c}",
            [
                r
                for r in rows
                if r["vary.register_trial.scan.points"] == str(p)
                and r["vary.register_trial.case"] == c
            ],
        )
        for p in (300, 500)
        for c in ("default", "outliers")
    ]:
        g = groups[label]
        accepted = [r for r in members if r["verdict"] == "accepted"]
        assert g["trials"] == len(members)
        assert g["accepted"] == len(accepted)
        assert g["ambiguous"] + g["rejected"] + g["accepted"] == len(members)
        wrong = [r for r in accepted if max(float(r[f"err_t{k}_m"]) for k in range(6)) > 2e-3]
        assert g["false_accepts"] == len(wrong)
        errors = [float(r[f"err_t{k}_m"]) for r in accepted for k in range(int(r["n_targets"]))]
        ratios = [
            float(r[f"err_t{k}_m"]) / float(r[f"tre_t{k}_m"])
            for r in accepted
            for k in range(int(r["n_targets"]))
        ]
        if errors:
            assert g["target_error"]["median"] == pytest.approx(np.median(errors), rel=1e-9)
            assert g["target_error"]["max"] == pytest.approx(max(errors), rel=1e-9)
            assert g["tre_ratio"]["median"] == pytest.approx(np.median(ratios), rel=1e-6)
        else:
            assert g["target_error"]["median"] is None
        times = [float(r["trial_seconds"]) for r in members]
        assert g["trial_seconds"]["median"] == pytest.approx(np.median(times), rel=1e-9)
    for name in ("target_error", "registration_error", "acceptance", "tre_calibration", "run_time"):
        png = (out / f"{name}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000

    # Rerunning resumes: nothing runs again, no row is rewritten.
    again = run_campaign(spec, out, workers=2, progress=False)
    assert (again.ran, again.skipped) == (0, 12)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "trials").glob("*.json")} == stamps
    assert read_rows(out / "results.csv") == rows

    # More trials: only the new ones run.
    more = plan_campaign(config, trials=4, vary=vary)
    grown = run_campaign(more, out, workers=1, progress=False)
    assert (grown.ran, grown.skipped) == (4, 12)
    assert len(read_rows(out / "results.csv")) == 16

    # Another campaign is refused in this folder.
    other = plan_campaign(config, trials=3, vary=["register_trial.scan.points=300"])
    with pytest.raises(CampaignError, match="another campaign"):
        run_campaign(other, out, progress=False)


def test_cli_campaign_runs_and_reports_bad_options(tmp_path: Path, capsys) -> None:
    config = cheap_config(tmp_path)
    out = tmp_path / "cli"
    code = main(["campaign", config, "--trials", "2", "--out", str(out), "--quiet"])
    assert code == 0
    text = capsys.readouterr().out
    assert "false accepts" in text and "2 trials run now" in text
    assert len(read_rows(out / "results.csv")) == 2
    bad = "cell.noise.laser_sigmaa=1e-4"
    assert main(["campaign", config, "--vary", bad, "--out", str(out)]) == 2
    assert "unknown key 'cell.noise.laser_sigmaa'" in capsys.readouterr().err
    assert main(["campaign", config, "--backend", "slurm", "--out", str(tmp_path / "x")]) == 2
    assert "unknown backend 'slurm'" in capsys.readouterr().err
