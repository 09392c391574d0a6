"""What a user's RAPID program's targets are called (operations.names): the touch robtargets'
names (the default), the one word of a comment line right above a touch's moves, or a table;
the exported program's touches, measured on the real cell, under the same names."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from pydantic import ValidationError

from models.registry import load_model
from scenarios.cli.app import main
from scenarios.configuration.config_files import load_config
from scenarios.jobs.exported_run import job_targets
from scenarios.offline.operations import program_targets, read_user_program
from scenarios.offline.settings import OperationsSection
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.touches import touch_operations

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "my_cell"

_POSE = "[0,1,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]"
#: Four touches, written here: a naming comment right above the first group's approach; a
#: comment of three words above the second (a remark, not a name); a blank line between the
#: comment and the third group; a comment between the fourth's approach and touch (not above
#: its group: with the pattern, no name).
MODULE = f"""MODULE Holes
  PERS tooldata tPen := [TRUE,[[0,0,100],[1,0,0,0]],[1,[0,0,50],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjPlate := [FALSE,TRUE,"",[[800,0,400],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget pA1 := [[0,0,50],{_POSE}];
  CONST robtarget pT1 := [[0,0,0],{_POSE}];
  CONST robtarget pA2 := [[40,0,50],{_POSE}];
  CONST robtarget pT2 := [[40,0,0],{_POSE}];
  CONST robtarget pA3 := [[80,0,50],{_POSE}];
  CONST robtarget pT3 := [[80,0,0],{_POSE}];
  CONST robtarget pA4 := [[120,0,50],{_POSE}];
  CONST robtarget pT4 := [[120,0,0],{_POSE}];
  PROC main()
    ! entry_left
    MoveJ pA1, v500, z10, tPen\\WObj:=wobjPlate;
    MoveL pT1, v20, fine, tPen\\WObj:=wobjPlate;
    MoveL pA1, v100, z10, tPen\\WObj:=wobjPlate;
    ! touch the right one
    MoveJ pA2, v500, z10, tPen\\WObj:=wobjPlate;
    MoveL pT2, v20, fine, tPen\\WObj:=wobjPlate;
    MoveL pA2, v100, z10, tPen\\WObj:=wobjPlate;
    ! entry_far

    MoveJ pA3, v500, z10, tPen\\WObj:=wobjPlate;
    MoveL pT3, v20, fine, tPen\\WObj:=wobjPlate;
    MoveL pA3, v100, z10, tPen\\WObj:=wobjPlate;
    MoveJ pA4, v500, z10, tPen\\WObj:=wobjPlate;
    ! entry-back
    MoveL pT4, v20, fine, tPen\\WObj:=wobjPlate;
    MoveL pA4, v100, z10, tPen\\WObj:=wobjPlate;
  ENDPROC
ENDMODULE
"""


def test_a_comment_right_above_a_touch_s_moves_names_it() -> None:
    module = read_module(MODULE, name="holes.mod")
    ops = touch_operations(module, "wobjPlate")
    assert [op.name for op in ops] == ["pT1", "pT2", "pT3", "pT4"]  # as today
    assert [op.comment for op in ops] == ["entry_left", None, None, None]
    # With listed pairs: above the approach move when it is the move just before the touch,
    # else above the touch (pT4 listed with another approach than the move before it).
    pairs = [("pA1", "pT4"), ("pA1", "pT1"), ("pA3", "pT3"), ("pA4", "pT4")]
    assert [op.comment for op in touch_operations(module, "wobjPlate", pairs)] == [
        "entry-back",
        "entry_left",
        None,
        None,
    ]


def _user(tmp_path: Path, names: str | dict[str, str]) -> tuple[str, ...]:
    path = tmp_path / "holes.mod"
    path.write_text(MODULE)
    return read_user_program(OperationsSection(program=str(path), names=names)).names


def test_operations_names_robtargets_comments_or_a_table(tmp_path: Path) -> None:
    assert _user(tmp_path, "robtargets") == ("pT1", "pT2", "pT3", "pT4")
    assert _user(tmp_path, "comments") == ("entry_left", "pT2", "pT3", "pT4")
    table = {"PT2": "entry_right", "pT4": "entry_back"}  # RAPID's names: any case
    assert _user(tmp_path, table) == ("pT1", "entry_right", "pT3", "entry_back")
    with pytest.raises(RapidError, match=r"names pX9, not a touch robtarget .*pT1, pT2, pT3, pT4"):
        _user(tmp_path, {"pX9": "entry"})
    with pytest.raises(RapidError, match=r"pT1 \(line 15\) and pT3 \(line 24\) are both named A"):
        _user(tmp_path, {"pT1": "a", "pT3": "A"})
    with pytest.raises(RapidError, match=r"pT1 \(line 15\) and pT2 \(line 19\) are both named pT2"):
        _user(tmp_path, {"pT1": "pT2"})
    assert OperationsSection().names == "robtargets"
    with pytest.raises(ValidationError, match="wobj, pairs and names belong to a RAPID program"):
        OperationsSection(names="comments")


def test_the_exported_program_s_touches_stand_for_the_named_targets() -> None:
    """The evaluator of the exported program finds a touched robtarget's target by its name."""
    config = load_config(EXAMPLE / "job.yaml", cell=EXAMPLE / "cell.yaml")
    section = config.operations.model_copy(update={"names": "comments"})
    user = read_user_program(section)
    assert user.names == ("kocher_right", "kocher_left", "parietal_right", "occipital_left")
    phantom, _ = load_model(config.cell.object.model, units=config.cell.object.units)
    virtual = replace(phantom, burr_holes=program_targets(user))
    assert [h.name for h in virtual.burr_holes] == list(user.names)
    targets = job_targets(config, virtual, user)
    assert targets.name_of("PPARIETAL_RIGHT") == "parietal_right"
    assert targets.name_of("pKocher_right") == "kocher_right"


#: The example's run at seed 0 with the robtargets' names (`twincell run
#: examples/my_cell/job.yaml --cell examples/my_cell/cell.yaml --seed 0`): each target's error
#: [m], the job's execution and the exported module (filtered) run by the nominal controller.
SEED0_JOB_M = [1.801976970606851e-4, 3.028732002646785e-4, 2.892583366894457e-4, 1.787400099e-4]
SEED0_EXPORTED_M = [2.0358196456e-4, 3.031676283e-4, 2.805154826e-4, 1.894398588e-4]


@pytest.mark.slow
def test_the_example_named_by_its_comments(tmp_path: Path) -> None:
    """The example with operations.names: comments at seed 0: its targets, and the exported
    program's, carry the comments' names, and every figure is the robtargets-named run's
    (to a nanometre: the names take no part in any draw or computation; the last digits
    may move with the numerical libraries' versions, by a few hundredths of a nanometre)."""
    code = main(
        ["run", str(EXAMPLE / "job.yaml"), "--cell", str(EXAMPLE / "cell.yaml"), "--seed", "0",
         "--set", "operations.names=comments", "--set", "output.rrd=false",
         "--set", "output.plots=false", "--out", str(tmp_path), "--quiet"]
    )  # fmt: skip
    assert code == 0
    result = json.loads((tmp_path / "latest" / "results.json").read_text())
    names = ["kocher_right", "kocher_left", "parietal_right", "occipital_left"]
    assert [t["name"] for t in result["targets"]] == names
    assert [t["name"] for t in result["exported_program"]["targets"]] == names
    job = [t["error_m"] for t in result["targets"]]
    exported = [t["error_m"] for t in result["exported_program"]["targets"]]
    assert job == pytest.approx(SEED0_JOB_M, abs=1e-9)
    assert exported == pytest.approx(SEED0_EXPORTED_M, abs=1e-9)
