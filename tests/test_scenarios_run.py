"""`twincell run` of the skull job end to end (short scan): the run folder, results.json,
the RAPID program, the PLY scan and the rerun recording (checked with `rerun rrd verify`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from cell import FixedMesh
from cell.sim import make_cell
from models import cache
from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import object_models
from scenarios.offline import plan_cache
from scenarios.outputs.run_files import read_ply
from scenarios.outputs.run_folder import write_json
from scenarios.realcell.real_placement import draw_true_pose
from scenarios.realcell.setup import cell_config
from scenarios.results.json_converter import unstructure
from scenarios.results.results_file import read_results


@pytest.fixture
def folder(short_skull_run: Path) -> Path:
    """The short skull job (seed 11, tests/conftest.py's SHORT_SKULL), run once a session."""
    return short_skull_run


def test_run_folder_has_every_file(folder: Path) -> None:
    assert folder.name.startswith("short-")
    for name in ("config.yaml", "results.json", "scan.ply", "program.mod", "run.rrd"):
        assert (folder / name).is_file(), name
    assert (folder / "registration.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (folder / "targets.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(folder.glob(".*"))  # no temporary file left behind
    # The resolved config reloads to the same configuration.
    written = load_config(folder / "config.yaml")
    assert written.seed == 11 and written.localization.scan.speed_m_s == 0.25


def test_results_json_has_the_keys_and_consistent_numbers(folder: Path) -> None:
    results = json.loads((folder / "results.json").read_text())
    assert results["status"] == "complete" and results["job"] == "short"
    assert results["seed"] == 11 and results["scan_points"] >= 10_000
    reg = results["registration"]
    for key in ("rms_m", "rotation_error_deg", "translation_error_m", "ambiguity", "verdict"):
        assert reg[key] is not None, key
    assert reg["verdict"] == "accepted" and reg["seconds"] > 0
    errors = np.array([t["error_m"] for t in results["targets"]])
    assert len(errors) == 4
    for t in results["targets"]:
        assert t["predicted_tre_m"] > 0
        gap = np.linalg.norm(np.subtract(t["p_achieved_base_m"], t["p_true_base_m"]))
        assert t["error_m"] == pytest.approx(gap, rel=1e-9)
    assert results["target_error_rms_m"] == pytest.approx(np.sqrt(np.mean(errors**2)))
    assert results["target_error_max_m"] == pytest.approx(errors.max())
    assert results["target_error_max_m"] < 1.5e-3
    timings = results["timings_s"]
    assert all(timings[k] > 0 for k in ("scan", "register", "execute", "total"))
    assert np.asarray(read_ply(folder / "scan.ply")).shape == (results["scan_points"], 3)


def test_the_scan_plan_is_the_one_cached_under_the_key_results_json_names(folder: Path) -> None:
    results = json.loads((folder / "results.json").read_text())
    key = results["plan_cache"]
    if not cache.enabled():
        assert key is None
        return
    stored = plan_cache.read_plan(plan_cache.folder() / f"{key}.npz")
    chosen = [c["name"] for c in results["scan_plan"]["chosen"]]
    assert [c.name for c in stored.chosen] == chosen
    assert np.array_equal(stored.predicted_tre_m, results["scan_plan"]["predicted_tre_m"])


def test_results_json_reads_back_typed_as_written(folder: Path, tmp_path: Path) -> None:
    """A real run's results.json, read back (scenarios.results.results_file.read_results), writes
    the same mapping again; its typed figures are the file's."""
    results = json.loads((folder / "results.json").read_text())
    typed = read_results(folder)
    write_json(tmp_path / "again.json", unstructure(typed))  # as the runner writes it
    assert json.loads((tmp_path / "again.json").read_text()) == results
    assert typed.target_error_max_m == results["target_error_max_m"]
    assert [t.name for t in typed.targets] == [t["name"] for t in results["targets"]]
    assert typed.match is not None and typed.match.starts == results["registration"]["starts"]


def test_true_targets_agree_with_an_independent_rebuild_of_the_truth(folder: Path) -> None:
    """The real phantom's pose follows from the seed alone: rebuild the cell (no motion) and
    place the real targets; the run's evaluator must have used the same points."""
    results = json.loads((folder / "results.json").read_text())
    config = load_config(folder / "config.yaml")
    _, real = object_models(config)
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 5]))
    T_table_true = draw_true_pose(config.cell.object.placement, real.mesh.vertices, rng)
    fixture = FixedMesh("object", real.mesh.vertices, real.mesh.faces, T_table_true)
    _, truth = make_cell(cell_config(config.cell.noise, config.seed, (fixture,)))
    assert results["table_position_m"] == 0.0  # the rebuilt table sits there too
    T = truth.T_base_object("object")
    offset = config.operations.touch_offset_m
    for hole, row in zip(real.burr_holes, results["targets"], strict=True):
        p = T[:3, :3] @ (hole.p_entry - offset * hole.direction) + T[:3, 3]
        # The table's per-move repeatability (0.01 mm sigma) separates the two.
        assert np.linalg.norm(p - row["p_true_base_m"]) < 1e-4


def test_program_module_is_written(folder: Path) -> None:
    text = (folder / "program.mod").read_text()
    assert text.startswith("MODULE ") and text.rstrip().endswith("ENDMODULE")
    assert text.count("MoveL") == 8 and text.count("MoveJ") == 4


def test_the_calibrated_arm_and_the_targets_are_exported(folder: Path) -> None:
    """The calibrated arm (URDF), the tool's TCP (tooldata.json) and the corrected targets
    (targets.csv) agree: the URDF's flange at each target's joints, with the tool's TCP, is
    the target's pose (the program was solved with the calibrated arm); the nominal arm is
    exported too and differs from it by the calibration's correction."""
    import csv

    import pinocchio as pin

    calibrated = pin.buildModelFromUrdf(str(folder / "robot_calibrated.urdf"))
    nominal = pin.buildModelFromUrdf(str(folder / "robot_nominal.urdf"))
    tool = json.loads((folder / "tooldata.json").read_text())
    assert tool["tool"] == "screwer" and tool["rapid"].startswith("PERS tooldata tScrewer")
    T_flange_tcp = np.array(tool["T_flange_tcp"])
    rows = list(csv.DictReader((folder / "targets.csv").read_text().splitlines()))
    assert len(rows) == 8  # 4 operations, approach and touch
    gaps = []
    for row in rows:
        q = np.array([float(row[f"q{k}_link_rad"]) for k in range(1, 7)])
        poses = []
        for model in (calibrated, nominal):
            data = model.createData()
            pin.framesForwardKinematics(model, data, q)
            T = data.oMf[model.getFrameId("flange")].homogeneous @ T_flange_tcp
            poses.append(T)
        p_target = np.array([float(row[k]) for k in ("x_m", "y_m", "z_m")])
        assert np.linalg.norm(poses[0][:3, 3] - p_target) < 1e-5  # the IK's tolerance
        gaps.append(np.linalg.norm(poses[1][:3, 3] - p_target))
    # The nominal arm puts the tool 0.1-1 mm off: what the calibration corrected.
    assert 1e-4 < max(gaps) < 2e-3


def test_rrd_file_verifies(folder: Path) -> None:
    rerun = Path(sys.executable).with_name("rerun")
    done = subprocess.run(
        [str(rerun), "rrd", "verify", str(folder / "run.rrd")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "verified without error" in done.stdout + done.stderr


def test_latest_points_at_the_run(folder: Path) -> None:
    latest = folder.parent / "latest"
    assert latest.is_symlink() and latest.resolve() == folder
    config = yaml.safe_load((folder / "config.yaml").read_text())
    assert config["kind"] == "cell" and config["name"] == "short"
