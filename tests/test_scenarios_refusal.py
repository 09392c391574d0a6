"""An object whose pose cannot be told (a sphere: any rotation fits), scanned with the fixed
passes, is refused after the scan, before any motion towards it; the run says why. (The
chosen plan refuses it earlier, at set-up: tests/test_scan_plan.py.)"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import trimesh

from scenarios.cli.app import main


@pytest.mark.slow
def test_a_sphere_is_refused_before_any_motion_towards_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mesh = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=4, radius=80.0).export(mesh)  # millimetres
    out = tmp_path / "runs"
    code = main(
        ["run", "skull", "--model", str(mesh), "--units", "mm", "--out", str(out), "--no-rrd",
         "--set", "localization.scan.plan=fixed"]
    )  # fmt: skip
    assert code == 3  # refused: neither success (0) nor a user error (2)
    err = capsys.readouterr().err
    assert "refused" in err and "ambigu" in err
    folder = (out / "latest").resolve()
    results = json.loads((folder / "results.json").read_text())
    assert results["status"] == "refused"
    assert results["registration"]["verdict"] in ("ambiguous", "rejected")
    assert results["scan_points"] > 10_000  # it was scanned well: the shape is the problem
    # No motion after the verdict: the controller's clock did not advance, the laser is
    # still in hand (no tool change to the pointer), and no program was written.
    assert results["motion_after_match_s"] == 0.0
    assert results["tool_in_hand"] == "laser"
    assert results["targets"] == []
    assert not (folder / "program.mod").exists()
    assert (folder / "scan.ply").is_file()
