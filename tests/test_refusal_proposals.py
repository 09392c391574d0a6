"""Each refusal of a job's checks before motion proposes a change the virtual cell has
checked, and the job run with that change applied as the refusal says it does its program:
the reach check (an object the UR5 cannot scan, a rack out of reach), the scan planner (more
points required than its budget can scan) and the pre-motion check (a user's touches
programmed into the bone)."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from scenarios.cli.app import main

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "my_cell"
sys.path.insert(0, str(Path(__file__).parent))
from test_user_program import SHORT, skull_module  # noqa: E402

#: The applied runs' quicker settings: what they show is that the check lets the program run.
QUICK = [*SHORT, "--set", "calibration.enabled=false"]


def _run(args: list[str], out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["run", *args, "--out", str(out), "--no-rrd", "--quiet"])
    return code, " ".join(capsys.readouterr().err.split())


def _ran(out: Path) -> dict:
    results = json.loads((out / "latest" / "results.json").read_text())
    assert results["status"] in ("complete", "at_risk"), results["reason"]
    assert results["targets"] and results["stage"] is None
    return results


@pytest.mark.slow
@pytest.mark.parametrize(
    ("job", "wrong", "proposed"),
    [
        (["skull", "--cell", "ur5"], "cell.object.placement.xy_m=[0.3,0.0]",
         "cell.object.placement.xy_m=[-0.1, 0.0]"),
        (["skull"], "cell.rack_xyz=[3.0,0.0,0.0]", "cell.rack_xyz=[0.0, -0.85, 0.0]"),
    ],
)  # fmt: skip
def test_a_reach_refusal_proposes_a_setting_that_does_the_job(
    job: list[str], wrong: str, proposed: str, tmp_path: Path, capsys
) -> None:
    code, err = _run([*job, "--set", wrong], tmp_path / "refused", capsys)
    assert code == 2 and "cannot do this job in this cell" in err
    found = re.search(r"proposed: --set (\S+=\[[^\]]*\])", err)
    assert found is not None and found.group(1) == proposed, err
    code, err = _run([*job, "--set", wrong, "--set", found.group(1), *QUICK], tmp_path, capsys)
    assert code in (0, 6), err
    _ran(tmp_path)


@pytest.mark.slow
def test_a_scan_plan_refusal_proposes_the_points_its_plan_can_scan(tmp_path: Path, capsys) -> None:
    """60,000 object points in a 30 s budget: the planner's passes see about 34,000; it
    proposes the min_points its plan meets the TRE goal with, and the job then runs."""
    job = [str(EXAMPLE / "job.yaml"), "--cell", str(EXAMPLE / "cell.yaml"),
           "--set", "localization.scan.planning.budget_s=30",
           "--set", "localization.scan.min_points=60000"]  # fmt: skip
    code, err = _run(job, tmp_path / "refused", capsys)
    assert code == 2 and "fewer than the 1.2 x 60000 the match requires" in err
    found = re.search(r"set (localization\.scan\.min_points=(\d+))", err)
    assert found is not None and 20_000 <= int(found.group(2)) < 60_000, err
    code, err = _run([*job, "--set", found.group(1), "--set", "calibration.enabled=false"],
                     tmp_path, capsys)  # fmt: skip
    assert code in (0, 6), err
    assert _ran(tmp_path)["scan_points"] >= int(found.group(2))


@pytest.mark.slow
def test_a_premotion_refusal_proposes_the_touches_to_write(tmp_path: Path, capsys) -> None:
    """Touches programmed 2 mm into the bone: each is proposed 3 mm or so back along the
    tool's axis, as the robtarget to write; written so, the program runs."""
    module = skull_module(gap_mm=-2.0)
    path = tmp_path / "deep.mod"
    path.write_text(module)
    code, err = _run(["skull", "--program", str(path), *QUICK], tmp_path / "refused", capsys)
    assert code == 3 and "touches object (2" in err
    proposals = re.findall(r"(pTouch\d): move it back (\d\.\d) mm along the tool's axis "
                           r"\(touch (\[\[[^\]]*\],\[[^\]]*\]\])", err)  # fmt: skip
    assert [name for name, _, _ in proposals] == [f"pTouch{k}" for k in range(4)], err
    assert all(3.0 <= float(mm) <= 4.0 for _, mm, _ in proposals)
    for name, _, pose in proposals:
        declared = re.compile(rf"(CONST robtarget {name} := )\[\[[^\]]*\],\[[^\]]*\]")
        assert declared.search(module) is not None
        module = declared.sub(lambda m, pose=pose: m.group(1) + pose[:-1], module)
    path.write_text(module)
    code, err = _run(["skull", "--program", str(path), *QUICK], tmp_path, capsys)
    assert code in (0, 6), err
    _ran(tmp_path)
