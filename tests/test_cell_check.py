"""`twincell check`: it passes on the default cell, writes its JSON, and can fail."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from cell.cell_errors import CellConfigError
from cell.sim.selfcheck import CheckReport
from scenarios.cli.app import main
from scenarios.cli.check_command import write_json

KEYS = {
    "mujoco_warnings",
    "fk_max_error_m",
    "ik_success_rate",
    "ik_max_error_m",
    "tool_changes",
    "table_travel_m",
    "laser_plane_max_error_m",
    "laser_sphere_max_error_m",
    "seconds",
}


def test_check_passes_on_the_default_cell(tmp_path: Path, capsys) -> None:
    out = tmp_path / "check.json"
    assert main(["check", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert set(report) >= KEYS
    assert report["passed"] is True
    assert report["mujoco_warnings"] == 0
    assert report["fk_max_error_m"] <= 1e-9
    assert report["ik_success_rate"] >= 0.99 and report["ik_max_error_m"] <= 1e-5
    assert report["tool_changes"] == {t: "ok" for t in ("gripper", "screwer", "ir", "laser")}
    assert abs(report["table_travel_m"] - 1.0) < 1e-3
    assert report["laser_plane_max_error_m"] <= 1e-6
    assert report["laser_sphere_max_error_m"] <= 1e-6
    assert "laser sphere" in capsys.readouterr().out


def test_each_criterion_can_fail() -> None:
    good = CheckReport(0, 0.0, 1.0, 0.0, {"laser": "ok"}, 1.0, 0.0, 0.0, 1.0)
    assert good.passed
    bad = [
        replace(good, mujoco_warnings=1),
        replace(good, fk_max_error_m=2e-9),
        replace(good, ik_success_rate=0.98),
        replace(good, ik_max_error_m=2e-5),
        replace(good, tool_changes={"laser": "not back in its slot"}),
        replace(good, table_travel_m=0.9),
        replace(good, laser_plane_max_error_m=2e-6),
        replace(good, laser_sphere_max_error_m=2e-6),
    ]
    for report in bad:
        assert not report.passed
        assert sum(not ok for ok in report.criteria().values()) == 1


def test_check_report_to_a_missing_folder_is_refused(tmp_path: Path) -> None:
    report = CheckReport(0, 0.0, 1.0, 0.0, {}, 1.0, 0.0, 0.0, 0.0)
    with pytest.raises(CellConfigError, match="does not exist"):
        write_json(report, tmp_path / "no" / "check.json")
    write_json(report, tmp_path / "check.json")
    assert json.loads((tmp_path / "check.json").read_text())["passed"] is report.passed
