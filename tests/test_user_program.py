"""A user's own RAPID module drives the skull job: its work object's robtargets are the
operations, the run writes the module back with only the work object's oframe corrected, and
bad modules are refused before any simulation starts."""

from __future__ import annotations

import difflib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cell import nominal_T_base_table
from cell.irb2400_arm import irb2400
from models.registry import builtin_model
from scenarios.cli.app import main
from scenarios.configuration.config_files import load_config
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.rapid.rapid_text import configuration

SHORT = ["--set", "localization.scan.speed_m_s=0.25", "--set", "localization.scan.period_s=0.02"]


def _pose(T: np.ndarray) -> str:
    """A RAPID pose [[x,y,z],[q1,q2,q3,q4]] in mm, scalar-first quaternion."""
    q = Rotation.from_matrix(T[:3, :3]).as_quat(scalar_first=True)
    q = q if q[0] >= 0 else -q
    p = T[:3, 3] * 1e3
    return f"[[{p[0]:.3f},{p[1]:.3f},{p[2]:.3f}],[{q[0]:.9f},{q[1]:.9f},{q[2]:.9f},{q[3]:.9f}]]"


def _frame(p: np.ndarray, z: np.ndarray) -> np.ndarray:
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, p
    return T


def skull_module(wobj_offset_mm: float = 0.0, gap_mm: float = 1.0) -> str:
    """The skull's burr-hole touches as a RobotStudio user would program them on the virtual
    cell: the work object on the phantom's nominal pose (table at 0), the pointer's ball
    (3 mm radius, its centre the TCP) `gap_mm` before each entry (negative: into the
    bone), approached 60 mm back along the trajectory, each robtarget's configuration data
    the nominal arm's solution (as RobotStudio writes them)."""
    config = load_config("skull")
    skull = builtin_model("skull", 0)
    T_base_object = nominal_T_base_table(0.0) @ nominal_pose(
        config.cell.object.placement, skull.mesh.vertices
    )
    T_base_object[0, 3] += wobj_offset_mm * 1e-3
    eax = "[0,9E+09,9E+09,9E+09,9E+09,9E+09]"
    lines = [
        "MODULE SkullProgram",
        "  ! Burr-hole touches programmed in RobotStudio on the virtual cell.",
        "  PERS tooldata tPointer := [TRUE,[[0,0,200],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wobjSkull := [FALSE,TRUE,"",{_pose(T_base_object)},[[0,0,0],[1,0,0,0]]];',
        "  CONST speeddata vTouch := [20,500,5000,1000];",
    ]
    kin = irb2400().kinematics().for_tool("screwer")
    T_tcp = np.eye(4)
    T_tcp[2, 3] = 0.2
    q = kin.lower / 2 + kin.upper / 2
    for k, hole in enumerate(skull.burr_holes):
        T_touch = _frame(hole.p_entry - (gap_mm + 3.0) * 1e-3 * hole.direction, hole.direction)
        T_app = T_touch.copy()
        T_app[:3, 3] -= 0.06 * hole.direction
        for name, T in ((f"pApp{k}", T_app), (f"pTouch{k}", T_touch)):
            q = kin.solve(T_base_object @ T, q, T_tcp, extra_seeds=30)
            conf = ",".join(str(v) for v in configuration(kin, q))
            lines.append(f"  CONST robtarget {name} := [{_pose(T)[1:-1]},[{conf}],{eax}];")
    lines.append("  PROC main()")
    for k in range(len(skull.burr_holes)):
        lines += [
            f"    ! hole {k}",
            f"    MoveJ pApp{k}, v500, z10, tPointer\\WObj:=wobjSkull;",
            f"    MoveL pTouch{k}, vTouch, fine, tPointer\\WObj:=wobjSkull;",
            f"    MoveL pApp{k}, v100, z10, tPointer\\WObj:=wobjSkull;",
        ]
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)


def _rapidcheck(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "rapidchecker", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("program")
    module = root / "skull_program.mod"
    module.write_text(skull_module())
    out = root / "runs"
    args = ["run", "skull", "--program", str(module), "--out", str(out), "--no-rrd", "--quiet"]
    assert main([*args, *SHORT]) == 0
    return module, (out / "latest").resolve()


@pytest.mark.slow
def test_the_program_s_touches_are_the_operations(run: tuple[Path, Path]) -> None:
    module, folder = run
    assert _rapidcheck(module).returncode == 0  # the input is valid RAPID
    results = json.loads((folder / "results.json").read_text())
    assert results["status"] == "complete"
    assert [t["name"] for t in results["targets"]] == [f"pTouch{k}" for k in range(4)]
    # Each touch lands on its robtarget on the real phantom (the evaluator's truth): the
    # skull job's tolerance for a short scan.
    errors = np.array([t["error_m"] for t in results["targets"]])
    assert errors.max() < 1.5e-3


@pytest.mark.slow
def test_the_module_comes_back_with_its_oframe_corrected_and_filtered(
    run: tuple[Path, Path],
) -> None:
    """Compensation filtered (the default; the skull job calibrates): the module comes back
    with its work object's oframe on the measured pose, its touches' robtargets and its
    tooldata rewritten for the calibrated arm, every other line as it was."""
    module, folder = run
    before = module.read_text().splitlines()
    after = (folder / "program.mod").read_text().splitlines()
    removed = [
        line[1:] for line in difflib.unified_diff(before, after, lineterm="", n=0)
        if line.startswith("-") and not line.startswith("---")
    ]  # fmt: skip
    kept = ("PERS tooldata tPointer", "PERS wobjdata wobjSkull", "CONST robtarget p")
    assert len(before) == len(after)
    assert removed == [line for line in before if any(k in line for k in kept)]
    assert _rapidcheck(folder / "program.mod").returncode == 0
    # The new oframe moves the object frame to the measured pose of the phantom (in the
    # table frame the calibration identified: microns from the nominal one here).
    from scenarios.rapid.reader import read_module

    read = read_module(folder / "program.mod")
    w = read.wobjs["wobjSkull"]
    results = json.loads((folder / "results.json").read_text())
    T_measured = nominal_T_base_table(0.0) @ np.array(results["registration"]["T_table_object"])
    np.testing.assert_allclose(w.T_base_uframe @ w.T_uframe_oframe, T_measured, atol=2e-5)
    assert results["exported_program"]["compensation"] == "filtered"
    # The filtered targets stay within the arm's error (a few tenths of a mm) of those
    # programmed, each moved.
    original = read_module(module)
    for name, target in original.targets.items():
        moved = np.linalg.norm(read.targets[name].T_wobj_tcp[:3, 3] - target.T_wobj_tcp[:3, 3])
        assert 1e-6 < moved < 2e-3, name


def test_bad_modules_are_refused_before_the_cell_starts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = skull_module()
    cases = {
        "syntax": (good.replace("vTouch, fine", "vTouch fine", 1), "line"),
        "instruction": (good.replace("! hole 0", "Sing 3;", 1), "Sing"),
        "no robtarget": (
            good.replace("PROC main()", "PROC main()\n    WaitTime 1;").replace(
                "\\WObj:=wobjSkull", ""
            ),
            "work object",
        ),
        "frame": (skull_module(wobj_offset_mm=25.0), "25.0 mm"),
    }
    for label, (text, message) in cases.items():
        path = tmp_path / f"{label}.mod"
        path.write_text(text)
        out = tmp_path / label
        code = main(["run", "skull", "--program", str(path), "--out", str(out), "--no-rrd"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2, label
        assert message in err[-1] and "Traceback" not in "\n".join(err), (label, err)
        results = json.loads(((out / "latest") / "results.json").read_text())
        assert results["status"] == "incomplete"
        assert "scan_points" not in results  # stopped before the cell moved


@pytest.mark.slow
def test_a_program_into_the_bone_is_refused_before_it_moves(tmp_path: Path) -> None:
    """Touches programmed 2 mm into the bone: the pre-motion check follows the corrected
    program in the virtual cell, finds the pointer in the skull at every touch and refuses
    the run before any motion towards the object, naming the moves and the bodies."""
    path = tmp_path / "deep.mod"
    path.write_text(skull_module(gap_mm=-2.0))
    out = tmp_path / "runs"
    args = ["run", "skull", "--program", str(path), "--out", str(out), "--no-rrd", "--quiet"]
    assert main([*args, *SHORT, "--set", "calibration.enabled=false"]) == 3
    results = json.loads((out / "latest" / "results.json").read_text())
    assert results["status"] == "refused" and results["stage"] == "check"
    assert results["reason"].startswith("the corrected program collides")
    for k in range(4):
        assert f"pTouch{k}: approach -> touch: tool_screwer touches object" in results["reason"]
    assert results["targets"] == [] and results["program_file"] is None
    assert [s["code"] for s in results["supervision"]] == ["premotion"]


def _split(module: str) -> dict[str, str]:
    """The skull module as a task of three modules, as a controller's backup holds one: a
    system module with the tool, the work object and the speed; the robtargets and the
    motion routine in a program module; `main` in another that calls it."""
    lines = module.splitlines()
    data = [ln for ln in lines if "tooldata" in ln or "wobjdata" in ln or "speeddata" in ln]
    targets = [ln for ln in lines if "robtarget" in ln]
    body = lines[lines.index("  PROC main()") + 1 : lines.index("  ENDPROC")]
    return {
        "Data.sys": "\n".join(["MODULE SkullData(SYSMODULE, NOSTEPIN)", *data, "ENDMODULE", ""]),
        "SkullMotion.mod": "\n".join(
            ["MODULE SkullMotion", *targets, "  PROC Holes()", *body, "  ENDPROC", "ENDMODULE", ""]
        ),
        "SkullMain.mod": "\n".join(
            ["MODULE SkullMain", "  PROC main()", "    Holes;", "  ENDPROC", "ENDMODULE", ""]
        ),
    }


@pytest.mark.slow
def test_a_task_folder_runs_as_its_single_module_does(
    run: tuple[Path, Path], tmp_path: Path
) -> None:
    """The same program as a task of three modules and an encrypted one (a licensed system
    module, kept unread): the same operations and the same errors as the single module's run
    (same seed), the task written back with only the work object's module changed and the
    encrypted one as it was, and `twincell execute` runs the written-back task. Written back
    filtered: the module of the tool and the work object changes in those two lines, the one
    of the robtargets in those, the one with main not at all."""
    module, single = run
    task = tmp_path / "TASK1"
    task.mkdir()
    for name, text in _split(module.read_text()).items():
        (task / name).write_text(text)
    encrypted = bytes([0xFC, 0xD8, 0x1D, 0xE6, 0x07, 0x01]) + np.random.default_rng(1).bytes(900)
    (task / "License.sys").write_bytes(encrypted)
    out = tmp_path / "runs"
    args = ["run", "skull", "--program", str(task), "--out", str(out), "--no-rrd", "--quiet"]
    assert main([*args, *SHORT]) == 0
    folder = (out / "latest").resolve()
    mine = json.loads((folder / "results.json").read_text())
    theirs = json.loads((single / "results.json").read_text())
    assert mine["status"] == "complete"
    assert [t["name"] for t in mine["targets"]] == [t["name"] for t in theirs["targets"]]
    np.testing.assert_allclose(
        [t["error_m"] for t in mine["targets"]],
        [t["error_m"] for t in theirs["targets"]],
        atol=1e-9,
    )
    written = folder / "program"
    assert sorted(p.name for p in written.iterdir()) == sorted(
        [*_split(module.read_text()), "License.sys"]
    )
    assert (written / "License.sys").read_bytes() == encrypted
    assert (written / "SkullMain.mod").read_text() == (task / "SkullMain.mod").read_text()
    for name, kept in (
        ("Data.sys", ("tooldata tPointer", "wobjdata wobjSkull")),
        ("SkullMotion.mod", ("robtarget p",)),
    ):
        before = (task / name).read_text().splitlines()
        removed = [
            line[1:]
            for line in difflib.unified_diff(
                before, (written / name).read_text().splitlines(), lineterm="", n=0
            )
            if line.startswith("-") and not line.startswith("---")
        ]
        assert removed == [line for line in before if any(k in line for k in kept)], name
    assert main(["execute", str(folder), "--quiet"]) == 0
    executed = json.loads((folder / "execution.json").read_text())
    assert [t["name"] for t in executed["targets"]] == [t["name"] for t in theirs["targets"]]
