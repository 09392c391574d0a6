"""A module's robtargets and tooldata rewritten (the filtered export of a user's module): the
poses given read back within the text's precision, every other line as it was; and a user's
module written back nominal or refused filtering for a touch that is no robtarget."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from scenarios.offline.operations import read_user_program
from scenarios.offline.settings import OperationsSection
from scenarios.outputs.user_program_export import filter_refusal, written_back
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.robtarget_rewrite import TargetRewrite, with_rewritten
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import read_task

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "my_cell"

MODULE = """MODULE Holes
  ! Two touches and a spare point; the spare keeps its pose.
  PERS tooldata tPointer := [TRUE,[[0, 0, 200],[1, 0, 0, 0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjPlate := [FALSE,TRUE,"",[[800,0,400],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST speeddata vTouch := [20,500,5000,1000];
  CONST robtarget pApp := [[10,20,130],[0,1,0,0],[0,0,0,0],[250,9E+09,9E+09,9E+09,9E+09,9E+09]];
  LOCAL PERS robtarget pTouch := [[10, 20, 70], [0, 1, 0, 0], [0, 0, 0, 0],
    [250, 9E+09, 9E+09, 9E+09, 9E+09, 9E+09]];
  CONST robtarget pSpare := [[0,0,300],[0,1,0,0],[0,0,0,0],[250,9E+09,9E+09,9E+09,9E+09,9E+09]];
  PROC main()
    MoveJ pApp, v500, z10, tPointer\\WObj:=wobjPlate;
    MoveL pTouch, vTouch, fine, tPointer\\WObj:=wobjPlate;
    MoveL pApp, v100, z10, tPointer\\WObj:=wobjPlate;
    MoveJ pSpare, v500, z10, tPointer\\WObj:=wobjPlate;
  ENDPROC
ENDMODULE
"""


def _pose(rotvec: tuple[float, float, float], p_mm: tuple[float, float, float]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = np.array(p_mm) * 1e-3
    return T


def test_rewritten_robtargets_and_tooldata_read_back_and_nothing_else_changes(
    tmp_path: Path,
) -> None:
    """Known poses (mm and radians chosen here, not by the code) written into pApp, pTouch
    (named in another case) and tPointer read back with the reader within the text's precision
    (4 decimals of mm: 5e-8 m; 8 decimals of a quaternion: 1e-7 in each matrix entry); the
    configuration data as given, the external axes as written, every other line unchanged."""
    T_app = _pose((3.0, 0.1, -0.2), (12.3456, 19.87654, 131.5))
    T_touch = _pose((2.9, -0.15, 0.05), (11.0001, 21.5, 71.25))
    T_tcp = _pose((0.001, -0.002, 0.0005), (-0.0273, 0.0643, 199.4615))
    text = with_rewritten(
        MODULE,
        "holes.mod",
        {
            "pApp": TargetRewrite(T_app, (0, 1, -2, 1)),
            "ptouch": TargetRewrite(T_touch, (-1, 0, 2, 4)),
        },
        {"TPOINTER": T_tcp},
    )
    path = tmp_path / "holes.mod"
    path.write_text(text)
    read = read_task([path]).modules[0]
    for name, T, conf in (("pApp", T_app, (0, 1, -2, 1)), ("pTouch", T_touch, (-1, 0, 2, 4))):
        target = read.targets[name]
        np.testing.assert_allclose(target.T_wobj_tcp[:3, 3], T[:3, 3], atol=5.1e-8)
        np.testing.assert_allclose(target.T_wobj_tcp[:3, :3], T[:3, :3], atol=1e-7)
        assert tuple(int(c) for c in target.conf) == conf
        assert target.eax[0] == 250.0
    np.testing.assert_allclose(read.tools["tPointer"].T_flange_tcp, T_tcp, atol=1e-7)
    assert read.tools["tPointer"].mass_kg == 2.0
    before, after = MODULE.splitlines(), text.splitlines()
    assert len(before) == len(after)
    changed = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    assert changed == [2, 5, 6]  # the tooldata, pApp and pTouch
    assert after[6].startswith("  LOCAL PERS robtarget pTouch := [[11.0001, 21.5, 71.25], [")
    assert after[6].endswith(", [-1, 0, 2, 4],")
    assert after[7] == before[7]  # the external axes, on their own line
    assert after[5].startswith("  CONST robtarget pApp := [[12.3456,19.8765,131.5],[")


def test_a_name_that_is_no_robtarget_is_refused_naming_those_declared() -> None:
    with pytest.raises(RapidError, match=r"no robtarget 'pOther'.*pApp, pTouch, pSpare"):
        with_rewritten(MODULE, "holes.mod", {"pOther": TargetRewrite(np.eye(4), (0, 0, 0, 0))})
    with pytest.raises(RapidError, match="no tooldata 'vTouch'"):
        with_rewritten(MODULE, "holes.mod", {}, {"vTouch": np.eye(4)})


def test_the_user_module_written_back_nominal_changes_its_oframe_only() -> None:
    """Compensation nominal: burr_holes.mod comes back with only its wobjdata line changed,
    its oframe the pose given (4 decimals of mm)."""
    user = read_user_program(OperationsSection(program=str(EXAMPLE / "burr_holes.mod")))
    T_base_object = user.wobj.T_base_uframe @ _pose((0.0, 0.01, 0.2), (25.0, -7.5, 1.25))
    program = OfflineProgram("screwer", 0.0, np.eye(4), (), T_base_object)
    back = written_back(user, program)
    assert back.targets == () and back.tools == ()
    before, after = user.module.text.splitlines(), back.texts[0][1].splitlines()
    changed = [a for a, b in zip(before, after, strict=True) if a != b]
    assert len(changed) == 1 and "PERS wobjdata wobjPart" in changed[0]
    assert "[[25,-7.5,1.25],[" in back.texts[0][1]


def test_filtering_needs_each_touch_to_be_a_declared_robtarget(tmp_path: Path) -> None:
    """The example's module filters (its touches are robtargets); one whose first approach
    is an Offs expression cannot be filtered: the reason names it."""
    program = EXAMPLE / "burr_holes.mod"
    assert filter_refusal(read_user_program(OperationsSection(program=str(program)))) is None
    edited = tmp_path / "offs.mod"
    edited.write_text(
        program.read_text().replace("MoveJ pKocher_rightApp,", "MoveJ Offs(pKocher_right,0,0,60),")
    )
    user = read_user_program(OperationsSection(program=str(edited)))
    assert filter_refusal(user) == (
        "the touch target Offs(pKocher_right,0,0,60) is no robtarget declared in the program"
    )
