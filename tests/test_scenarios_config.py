"""Run configurations: validation errors name the key and the value; shipped configs load;
a failing run leaves results.json "incomplete" with the reason."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from scenarios.cli.app import main
from scenarios.configuration.cell_sections import CellSection, ObjectSection
from scenarios.configuration.config_error import ConfigError
from scenarios.configuration.config_files import (
    config_yaml,
    load_config,
    parse_config,
    shipped_names,
)
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.runner import RunOptions, run_job
from scenarios.offline.calibration_step import calibration_plan, calibration_priors


def test_shipped_configs_load_and_round_trip() -> None:
    assert {"paper", "skull", "assembly"} <= set(shipped_names())
    for name in ("paper", "skull", "assembly"):
        config = load_config(name)
        assert config.name == name
        again = parse_config(yaml.safe_load(config_yaml(config)))
        assert again == config


def test_a_sweep_of_the_truth_moves_no_prior() -> None:
    """The cell's errors (cell.noise: the simulated truth) scaled up and down: what the
    planning, the calibration and the matching are told (their data-sheet priors, the crop
    margin, the matcher's pass sigma) stays as configured."""
    base = load_config("skull")
    noise = base.cell.noise.model_dump()
    for factor in (0.0, 0.5, 3.0):
        scaled = {
            f"cell.noise.{k}": v * factor
            for k, v in noise.items()
            if isinstance(v, float) and not k.startswith("model_")
        }
        scaled["cell.noise.drives.repeat_sigma_rad"] = noise["drives"]["repeat_sigma_rad"] * factor
        scaled["cell.noise.tools.laser_mount_sigma_m"] = (
            noise["tools"]["laser_mount_sigma_m"] * factor
        )
        swept = load_config("skull", scaled)
        assert swept.cell.noise != base.cell.noise
        for section in ("calibration", "localization", "operations", "checks", "export"):
            assert getattr(swept, section) == getattr(base, section), section
        assert calibration_priors(swept.calibration) == calibration_priors(base.calibration)
        assert calibration_plan(swept.calibration, 3) == calibration_plan(base.calibration, 3)


def test_unknown_key_is_named(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("localization:\n  scan:\n    standof_m: 0.3\n")
    with pytest.raises(ConfigError, match=r"unknown key 'localization\.scan\.standof_m'"):
        load_config(path)


def test_bad_value_is_named_with_what_was_given() -> None:
    with pytest.raises(ConfigError, match=r"localization\.scan\.speed_m_s: .*greater than 0.*-1"):
        parse_config({"localization": {"scan": {"speed_m_s": -1}}})
    with pytest.raises(ConfigError, match=r"operations\.tool.*'drill'"):
        parse_config({"operations": {"tool": "drill"}})
    with pytest.raises(ConfigError, match=r"'kind' must be one of .*'welding'"):
        parse_config({"kind": "welding"})
    with pytest.raises(ConfigError, match=r"cell\.clock_utc: .*timezone.*'2026-01-05T08:00:00'"):
        parse_config({"cell": {"clock_utc": "2026-01-05T08:00:00"}})
    assert isinstance(ConfigError("x"), ValueError)


def test_bad_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such configuration file"):
        load_config(tmp_path / "missing.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("localization:\n  scan: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(broken)
    with pytest.raises(ConfigError, match="unknown job 'skul'; shipped: assembly, paper"):
        load_config("skul")


def test_cli_reports_a_bad_config_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("cell:\n  object:\n    placement:\n      range_tilt_deg: 90\n")
    assert main(["run", str(path), "--out", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cell.object.placement.range_tilt_deg" in err[0] and "90" in err[0]


def test_a_failing_run_leaves_results_incomplete_with_the_reason(tmp_path: Path) -> None:
    config = JobConfig(
        cell=CellSection(object=ObjectSection(model=str(tmp_path / "no_such_mesh.stl")))
    )
    with pytest.raises(Exception, match="no such file"):
        run_job(config, out=tmp_path / "runs", options=RunOptions(rrd=True))
    folder = (tmp_path / "runs" / "latest").resolve()
    results = json.loads((folder / "results.json").read_text())
    assert results["status"] == "incomplete"
    assert "no such file" in results["reason"]
    written = yaml.safe_load((folder / "config.yaml").read_text())
    assert written["cell"]["object"]["model"].endswith("no_such_mesh.stl")
    assert not (folder / "program.mod").exists()
    # The recording had started: it is removed, not left half written.
    assert not (folder / "run.rrd").exists() and not list(folder.glob(".*"))


def test_a_job_s_files_are_found_beside_its_yaml(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A mesh, a program and a targets file named relative to a job's YAML are found beside
    it, wherever the job runs from; a name that is not beside it (a built-in model) is kept."""
    job = tmp_path / "cell_project"
    job.mkdir()
    for name in ("part.stl", "touches.mod", "plan.json"):
        (job / name).write_text("")
    (job / "job.yaml").write_text(
        yaml.safe_dump(
            {
                "cell": {"object": {"model": "part.stl", "targets_file": "plan.json"}},
                "operations": {"program": "touches.mod"},
            }
        )
    )
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    config = load_config(job / "job.yaml")
    assert isinstance(config, JobConfig)
    assert config.cell.object.model == str(job / "part.stl")
    assert config.cell.object.targets_file == str(job / "plan.json")
    assert config.operations.program == str(job / "touches.mod")
    (job / "builtin.yaml").write_text(yaml.safe_dump({"cell": {"object": {"model": "skull"}}}))
    built_in = load_config(job / "builtin.yaml")
    assert isinstance(built_in, JobConfig) and built_in.cell.object.model == "skull"
