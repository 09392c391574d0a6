"""Reading a RobotStudio RAPID module, its approach/touch operations, and writing it back with
one work object's oframe corrected.

tests/data/rapid holds modules written by hand the way RobotStudio users write them. Ground
truth is worked out here by hand from the numbers in those files (rotations written out as
matrices, displacements added by hand), never by the code under test.
"""

from __future__ import annotations

import difflib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from scenarios.rapid.module import RapidModule
from scenarios.rapid.oframe import with_oframe
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.touches import touch_operations

DATA = Path(__file__).parent / "data" / "rapid"
TOUCH = DATA / "touch_plate.mod"
DRILL = DATA / "drill_sysmodule.mod"

# Rotations of the files' quaternions, by hand. q = [0,0,1,0]: 180 deg about y.
R_FLIP_Y = np.diag([-1.0, 1.0, -1.0])
# q = [0, 1/sqrt2, 1/sqrt2, 0]: 180 deg about (1,1,0)/sqrt2, R = 2 n n^T - I.
R_FLIP_XY = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
# q = [1/sqrt2, 0, 0, 1/sqrt2]: 90 deg about z.
R_Z90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
# q = [0,1,0,0]: 180 deg about x.
R_FLIP_X = np.diag([1.0, -1.0, -1.0])

# The files write 1/sqrt2 as 0.707106781 (9 digits): rotations are exact to ~1e-9.
ATOL_R = 1e-8
# Positions are mm with a few digits, converted to m: exact to float rounding.
ATOL_P = 1e-12


def _line(text: str, fragment: str) -> int:
    """1-based number of the first line of `text` containing `fragment`."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


def _check_pose(T: np.ndarray, R: np.ndarray, p_m: list[float]) -> None:
    assert T.shape == (4, 4)
    assert np.allclose(T[:3, :3], R, atol=ATOL_R)
    assert np.allclose(T[:3, 3], p_m, atol=ATOL_P)
    assert np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0])


def _rapidcheck(path: Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The RAPID grammar and format checker (rapidchecker) on one file, run from `cwd` (it
    reads a rapidchecker.toml there if any)."""
    return subprocess.run(
        [sys.executable, "-m", "rapidchecker", str(path)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def _oframe_span(text: str, wobj: str) -> tuple[int, int]:
    """[start, end) of the oframe (the 5th element) of `wobj`'s value, by counting brackets."""
    m = re.search(rf"wobjdata\s+{wobj}\s*:=\s*\[", text)
    assert m is not None
    depth, element, start = 1, 0, None
    for i in range(m.end(), len(text)):
        c = text[i]
        if c == "[":
            if depth == 1 and element == 4:
                start = i
            depth += 1
        elif c == "]":
            depth -= 1
            if depth == 1 and start is not None:
                return start, i + 1
        elif c == "," and depth == 1:
            element += 1
    raise AssertionError("no oframe")


@pytest.fixture(scope="module")
def touch() -> RapidModule:
    return read_module(TOUCH)


# --------------------------------------------------------------------------------------------
# Reader


def test_data_in_si_units(touch: RapidModule) -> None:
    text = TOUCH.read_text()
    assert touch.name == "TouchPlate" and touch.path == TOUCH and touch.text == text
    assert list(touch.tools) == ["tProbe"]
    tool = touch.tools["tProbe"]
    assert tool.robhold and tool.mass_kg == pytest.approx(1.2, abs=1e-12)
    _check_pose(tool.T_flange_tcp, np.eye(3), [0.0, 0.0, 0.150])
    assert np.allclose(tool.cog_m, [0.0, 0.0, 0.060], atol=ATOL_P)
    assert tool.line == _line(text, "PERS tooldata tProbe")

    assert list(touch.wobjs) == ["wobjPlate", "wobjTable"]
    plate = touch.wobjs["wobjPlate"]
    assert (plate.robhold, plate.ufprog, plate.ufmec) == (False, True, "")
    _check_pose(plate.T_base_uframe, R_Z90, [0.8, -0.2, 0.4])
    _check_pose(plate.T_uframe_oframe, np.eye(3), [0.0, 0.0, 0.0])
    assert plate.line == _line(text, "PERS wobjdata wobjPlate")
    _check_pose(touch.wobjs["wobjTable"].T_base_uframe, np.eye(3), [1.2, 0.0, 0.0])

    assert len(touch.targets) == 8
    t1 = touch.targets["pTouch1"]
    # [500,0,300] mm, [0,0,1,0]: 180 deg about y, so R = diag(-1, 1, -1).
    _check_pose(t1.T_wobj_tcp, R_FLIP_Y, [0.5, 0.0, 0.3])
    assert t1.conf.tolist() == [0, -1, 0, 1] and t1.conf.dtype.kind == "i"
    assert t1.eax.tolist() == [9e9] * 6  # written 9E9
    assert t1.line == _line(text, "CONST robtarget pTouch1")
    t2 = touch.targets["pTouch2"]
    assert t2.eax.tolist() == [250.0] + [9e9] * 5  # eax_a in mm as written; 9E+09 unused
    # Declared over two lines, its line is the first.
    t3 = touch.targets["pTouch3"]
    assert t3.line == _line(text, "CONST robtarget pTouch3") and t3.conf.tolist() == [-1, 0, 0, 0]
    _check_pose(touch.targets["pTouch4"].T_wobj_tcp, R_FLIP_XY, [0.7, 0.0, 0.31])

    # Other data are kept as literal values.
    assert touch.data["nApproach"].value == 50.0 and touch.data["nApproach"].storage == "CONST"
    assert touch.data["psCentre"].scope == "LOCAL" and touch.data["psCentre"].datatype == "pos"
    assert touch.data["wobjTable"].scope == "TASK"
    assert touch.data["psCentre"].value == (600.0, -40.0, 300.0)
    assert touch.data["sProbe"].value == "Probe A" and touch.data["bSimulate"].value is True
    assert touch.data["irTouch"].value is None and touch.data["irTouch"].text is None
    assert touch.data["vTouch"].text == "[20,500,5000,1000]"


def test_moves_in_the_order_of_the_text(touch: RapidModule) -> None:
    text = TOUCH.read_text()
    moves = touch.moves
    assert [m.instruction for m in moves] == (
        ["MoveAbsJ", "MoveJ"] + ["MoveJ", "MoveL", "MoveL"] * 3 + ["MoveL"] * 3 + ["MoveAbsJ"]
    ) + ["MoveL", "MoveL", "MoveC", "MoveL"]
    assert [m.routine for m in moves] == ["main"] * 15 + ["inspect"] * 4

    home = moves[0]
    assert (home.target, home.speed, home.zone, home.tool, home.wobj) == (
        "jHome",
        "v1000",
        "z50",
        "tProbe",
        None,
    )
    assert home.T_wobj_tcp is None and home.options == ("\\NoEOffs",)
    assert home.line == _line(text, "MoveAbsJ jHome\\NoEOffs, v1000, z50")

    app2 = moves[5]
    assert app2.target == "Offs(pTouch2,0,0,nApproach)" and app2.wobj == "wobjPlate"
    # Offs adds (0, 0, nApproach = 50) mm in the work object frame; orientation kept.
    _check_pose(app2.T_wobj_tcp, R_FLIP_Y, [0.65, 0.12, 0.35])

    app3 = moves[8]
    assert app3.target == "RelTool(pTouch3,0,0,-40)"
    # RelTool moves along the target's own z; with R = diag(-1, 1, -1) the tool's z is the
    # work object's -z, so -40 mm along the tool's z is +40 mm in the work object frame.
    _check_pose(app3.T_wobj_tcp, R_FLIP_Y, [0.62, -0.08, 0.34])

    app4, touch4 = moves[11], moves[12]
    assert app4.options == ("\\Conc", "\\Z:=8", "\\WObj:=wobjPlate") and app4.zone == "z5"
    assert touch4.speed == "vTouch" and touch4.options == ("\\V:=15", "\\WObj:=wobjPlate")
    assert touch4.zone == "fine" and touch4.line == _line(text, "MoveL pTouch4,")

    look = moves[15]
    assert look.target == "RelTool(pCheck,0,0,-20\\Rx:=90\\Rz:=90)"
    # pCheck [100,50,20] mm, identity: -20 mm along its z, then 90 deg about the tool's x and
    # then 90 deg about the NEW z (ABB's order x, y, z): the tool's x ends along the work
    # object's z, its y along -x, its z along -y (columns of R).
    R_look = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    _check_pose(look.T_wobj_tcp, R_look, [0.1, 0.05, 0.0])

    # Known only at run time: the FOR variable i.
    assert moves[16].target == "Offs(pCheck,i*nStep,0,0)" and moves[16].T_wobj_tcp is None

    arc = moves[17]
    assert arc.circle_point == "Offs(pCheck,10,10,0)" and arc.target == "Offs(pCheck,20,0,0)"
    assert arc.T_wobj_circle_point is not None
    _check_pose(arc.T_wobj_circle_point, np.eye(3), [0.11, 0.06, 0.02])
    _check_pose(arc.T_wobj_tcp, np.eye(3), [0.12, 0.05, 0.02])

    inline = moves[18]
    assert inline.target.startswith("[[150,50,20],[1,0,0,0]")
    _check_pose(inline.T_wobj_tcp, np.eye(3), [0.15, 0.05, 0.02])


def test_hand_written_style_and_numbers() -> None:
    drill = read_module(DRILL)
    assert drill.name == "DrillPlate"
    assert drill.tools["tDrill"].T_flange_tcp[2, 3] == pytest.approx(0.2205, abs=ATOL_P)
    oframe = drill.wobjs["wobjDrill"].T_uframe_oframe
    # [0.9961947, 0, 0, 0.0871557]: 10 deg about z (cos 5 deg, sin 5 deg to 7 digits).
    c, s = np.cos(np.radians(10)), np.sin(np.radians(10))
    assert np.allclose(oframe[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-6)
    assert np.allclose(oframe[:3, 3], [0.010, -0.005, 0.0], atol=ATOL_P)
    # -1.5e-3 mm is -1.5e-6 m.
    _check_pose(drill.targets["pDrill"].T_wobj_tcp, R_FLIP_X, [0.040, 0.025, -1.5e-6])
    assert drill.targets["pDrill"].eax.tolist() == [9e9] * 6


# A minimal module for the variants below; its line numbers are used in the expectations.
TINY = """MODULE Tiny
  PERS tooldata tPen := [TRUE,[[0,0,100],[1,0,0,0]],[0.5,[0,0,50],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjA := [FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  PERS wobjdata wobjB := [FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget pA := [[0,0,50],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pT := [[0,0,0],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveJ pA, v100, z10, tPen\\WObj:=wobjA;
    MoveL pT, v10, fine, tPen\\WObj:=wobjA;
    MoveL pA, v100, z10, tPen\\WObj:=wobjA;
  ENDPROC
ENDMODULE
"""


def test_keywords_and_names_are_case_insensitive() -> None:
    module = read_module(TINY.lower())
    assert module.name == "tiny"
    ops = touch_operations(module, "WOBJA")
    assert [op.name for op in ops] == ["pt"]
    _check_pose(ops[0].T_wobj_touch, R_FLIP_Y, [0.0, 0.0, 0.0])
    _check_pose(ops[0].T_wobj_approach, R_FLIP_Y, [0.0, 0.0, 0.05])


def test_arguments_parameters_and_routine_data() -> None:
    text = TINY.replace(
        "  PROC main()\n",
        "  CONST num nZ := 100;\n"
        "  PROC touchAt(robtarget pX, \\num depth)\n"
        "    VAR robtarget pLocal := [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
        "    MoveL pX, v10, fine, tPen\\WObj:=wobjA;\n"
        "    MoveL Offs(pLocal, 2*5, -(3), nZ/2 - 50 + 50), v10, z1, tool0\\WObj:=wobj0;\n"
        "  ENDPROC\n"
        "  PROC main()\n"
        "    touchAt pT;\n",
    )
    module = read_module(text)
    by_param, local = module.moves[0], module.moves[1]
    assert by_param.routine == "touchAt" and by_param.T_wobj_tcp is None  # known at run time
    # pLocal [1,2,3] mm + (10, -3, 50) mm; tool0 and wobj0 are the controller's own.
    _check_pose(local.T_wobj_tcp, np.eye(3), [0.011, -0.001, 0.053])
    assert "pLocal" not in module.targets and "nZ" in module.data
    with pytest.raises(RapidError, match="looks like a file name"):
        read_module(str(TOUCH))


def test_quaternion_slightly_off_unit_length_is_normalised() -> None:
    # |q| = 1.0004: within 1e-3 of 1, read as the unit quaternion [0,0,1,0].
    module = read_module(TINY.replace("[[0,0,0],[0,0,1,0]", "[[0,0,0],[0,0,1.0004,0]"))
    R = module.targets["pT"].T_wobj_tcp[:3, :3]
    assert np.allclose(R, R_FLIP_Y, atol=1e-12)


@pytest.mark.parametrize(
    ("old", "new", "line", "words"),
    [
        # A missing ';': the line of the statement that lacks it.
        ("fine, tPen\\WObj:=wobjA;", "fine, tPen\\WObj:=wobjA", 9, ["missing ';'", "MoveL"]),
        ("pT := [[0,0,0],", "pT := [[0,0,0,", 6, ["unbalanced brackets"]),
        ("9E9,9E9]];\n  PROC", "9E9,9E9]]];\n  PROC", 6, ["unbalanced brackets", "']'"]),
        ("  ENDPROC\n", "", 11, ["PROC main (line 7)", "no ENDPROC"]),
        ("ENDMODULE\n", "", 1, ["no ENDMODULE"]),
        ("MoveL pT,", "MoveL 1pT,", 9, ["'1pT' starts with a digit"]),
        ("MODULE Tiny", "MODULE 2Tiny", 1, ["'2Tiny' starts with a digit"]),
        ("MoveL pT,", "MoveL pX,", 9, ["target pX", "not declared"]),
        ("MoveL pT,", "MoveL Offs(pX,0,0,10),", 9, ["target pX", "not declared"]),
        ("fine, tPen", "fine, tPin", 9, ["tool tPin", "not declared"]),
        ("fine, tPen\\WObj:=wobjA", "fine, tPen\\WObj:=wobjC", 9, ["wobjC", "not declared"]),
        ("MoveL pT,", "MoveL tPen,", 9, ["tPen", "tooldata, not a robtarget"]),
        ("[[0,0,0],[0,0,1,0]", "[[0,0,0],[0,0,1.1,0]", 6, ["quaternion", "norm 1.1"]),
        (
            "    MoveL pA, v100",
            "    IF TRUE THEN\n    MoveL pA, v100",
            12,
            ["IF (line 10)", "no ENDIF"],
        ),
        ('"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\n  PERS wobjdata wobjB', '"x', 3, []),
    ],
    ids=[
        "missing-semicolon",
        "unclosed-bracket",
        "extra-bracket",
        "missing-endproc",
        "missing-endmodule",
        "digit-name",
        "digit-module-name",
        "undeclared-target",
        "undeclared-offs-target",
        "undeclared-tool",
        "undeclared-wobj",
        "target-of-wrong-type",
        "non-unit-quaternion",
        "missing-endif",
        "unterminated-string",
    ],
)
def test_bad_input_names_the_file_and_line(old: str, new: str, line: int, words: list[str]) -> None:
    assert old in TINY
    with pytest.raises(RapidError) as info:
        read_module(TINY.replace(old, new), name="tiny.mod")
    message = str(info.value)
    assert message.startswith(f"tiny.mod, line {line}: "), message
    for word in words:
        assert word in message, message


def test_errors_from_a_file_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.mod"
    path.write_text(TINY.replace("MoveL pT,", "MoveL pT"))
    with pytest.raises(RapidError, match=r"broken\.mod, line 9: missing ';'"):
        read_module(path)


# --------------------------------------------------------------------------------------------
# Touch operations


def test_touch_operations_from_the_pattern(touch: RapidModule) -> None:
    text = TOUCH.read_text()
    ops = touch_operations(touch, "wobjPlate")
    assert [op.name for op in ops] == ["pTouch1", "pTouch2", "pTouch3", "pTouch4"]
    assert [op.speed_touch for op in ops] == ["vTouch"] * 4
    assert [op.line for op in ops] == [_line(text, f"MoveL pTouch{k},") for k in range(1, 5)]
    # Hole 1: approach 50 mm above (the transit MoveJ pAbove before it is not an approach).
    _check_pose(ops[0].T_wobj_approach, R_FLIP_Y, [0.5, 0.0, 0.35])
    _check_pose(ops[0].T_wobj_touch, R_FLIP_Y, [0.5, 0.0, 0.3])
    # Hole 2: Offs(pTouch2,0,0,nApproach), nApproach = 50 mm.
    _check_pose(ops[1].T_wobj_approach, R_FLIP_Y, [0.65, 0.12, 0.35])
    _check_pose(ops[1].T_wobj_touch, R_FLIP_Y, [0.65, 0.12, 0.3])
    # Hole 3: RelTool(pTouch3,0,0,-40) is 40 mm up in the work object.
    _check_pose(ops[2].T_wobj_approach, R_FLIP_Y, [0.62, -0.08, 0.34])
    _check_pose(ops[2].T_wobj_touch, R_FLIP_Y, [0.62, -0.08, 0.3])
    # Hole 4: a MoveL \Conc approach 20 mm above.
    _check_pose(ops[3].T_wobj_approach, R_FLIP_XY, [0.7, 0.0, 0.33])
    _check_pose(ops[3].T_wobj_touch, R_FLIP_XY, [0.7, 0.0, 0.31])


def test_touch_operations_from_explicit_pairs(touch: RapidModule) -> None:
    pairs = [("Offs(pTouch2, 0, 0, nApproach)", "pTouch2"), ("pApp1", "PTOUCH1")]
    ops = touch_operations(touch, "wobjPlate", pairs)
    assert [op.name for op in ops] == ["pTouch2", "pTouch1"]
    _check_pose(ops[0].T_wobj_approach, R_FLIP_Y, [0.65, 0.12, 0.35])
    _check_pose(ops[1].T_wobj_approach, R_FLIP_Y, [0.5, 0.0, 0.35])
    _check_pose(ops[1].T_wobj_touch, R_FLIP_Y, [0.5, 0.0, 0.3])
    with pytest.raises(RapidError, match="no move with wobjPlate goes to the touch target 'pA'"):
        touch_operations(touch, "wobjPlate", [("pApp1", "pA")])


def test_a_pattern_that_cannot_be_read_asks_for_the_pairs() -> None:
    # A touch right after another touch that does not go back to its approach.
    two = TINY.replace(
        "  CONST robtarget pT :=",
        "  CONST robtarget pU := [[10,0,0],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
        "  CONST robtarget pT :=",
    ).replace("MoveL pA, v100, z10", "MoveL pU, v10, fine")
    module = read_module(two)
    with pytest.raises(RapidError, match=r"line 11: .*list the \(approach, touch\) target pairs"):
        touch_operations(module, "wobjA")
    ops = touch_operations(module, "wobjA", [("pA", "pT"), ("pT", "pU")])
    _check_pose(ops[1].T_wobj_approach, R_FLIP_Y, [0.0, 0.0, 0.0])
    _check_pose(ops[1].T_wobj_touch, R_FLIP_Y, [0.01, 0.0, 0.0])
    # A touch with no approach before it.
    first = read_module(TINY.replace("MoveJ pA, v100, z10", "MoveL pT, v10, fine"))
    with pytest.raises(RapidError, match=r"line 8: the touch MoveL pT has no MoveJ or MoveL"):
        touch_operations(first, "wobjA")
    # Going back to the approach with a fine zone is the move back, not a touch.
    back = read_module(TINY.replace("MoveL pA, v100, z10", "MoveL pA, v100, fine"))
    assert [op.name for op in touch_operations(back, "wobjA")] == ["pT"]


def test_a_work_object_with_no_robtarget() -> None:
    module = read_module(TINY, name="tiny.mod")
    with pytest.raises(RapidError, match=r"line 4: the work object wobjB holds no robtarget"):
        touch_operations(module, "wobjB")
    with pytest.raises(RapidError, match="no wobjdata 'wobjZ'"):
        touch_operations(module, "wobjZ")


# --------------------------------------------------------------------------------------------
# Writer


def _T(rotvec: list[float], p_m: list[float]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = p_m
    return T


def _angle(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle [rad] of R_a^T R_b, from its trace (stable near 0 through the sine)."""
    R = R_a.T @ R_b
    s = np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2
    return float(np.arctan2(s, (np.trace(R) - 1) / 2))


def _same_module_but_oframe(a: RapidModule, b: RapidModule, wobj: str) -> None:
    assert (a.name, list(a.targets), list(a.tools), list(a.wobjs)) == (
        b.name,
        list(b.targets),
        list(b.tools),
        list(b.wobjs),
    )
    for name, t in a.targets.items():
        u = b.targets[name]
        assert np.array_equal(t.T_wobj_tcp, u.T_wobj_tcp) and t.line == u.line
        assert np.array_equal(t.conf, u.conf) and np.array_equal(t.eax, u.eax)
    for m, n in zip(a.moves, b.moves, strict=True):
        assert (m.instruction, m.target, m.speed, m.zone, m.tool, m.wobj, m.line) == (
            n.instruction,
            n.target,
            n.speed,
            n.zone,
            n.tool,
            n.wobj,
            n.line,
        )
        assert (m.T_wobj_tcp is None and n.T_wobj_tcp is None) or np.array_equal(
            m.T_wobj_tcp, n.T_wobj_tcp
        )
    for name, w in a.wobjs.items():
        assert np.array_equal(w.T_base_uframe, b.wobjs[name].T_base_uframe)
        if name != wobj:
            assert np.array_equal(w.T_uframe_oframe, b.wobjs[name].T_uframe_oframe)


def test_with_oframe_changes_the_oframe_only(touch: RapidModule, tmp_path: Path) -> None:
    T_new = _T([0.01, -0.02, 0.03], [0.0123, -0.0045, 0.0067])
    text = with_oframe(touch, "wobjPlate", T_new)
    old = touch.text

    # Line by line: exactly one line changed, the oframe's own line.
    changed = [
        d for d in difflib.ndiff(old.splitlines(True), text.splitlines(True)) if d[0] in "+-"
    ]
    assert len(changed) == 2 and changed[0].startswith("-     [[0,0,0],[1,0,0,0]]];")
    # Character by character: every change lies inside the oframe's brackets.
    start, end = _oframe_span(old, "wobjPlate")
    assert old[start:end] == "[[0,0,0],[1,0,0,0]]"
    matcher = difflib.SequenceMatcher(None, old, text, autojunk=False)
    for tag, i1, i2, _j1, _j2 in matcher.get_opcodes():
        if tag != "equal":
            assert start <= i1 and i2 <= end, (tag, old[i1:i2])
    assert old[:start] == text[:start] and old[end:] == text[len(text) - (len(old) - end) :]

    # Re-read: the new oframe to the printed precision (1e-4 mm, 1e-8 in the quaternion).
    path = tmp_path / "touch_plate.mod"
    path.write_text(text)
    again = read_module(path)
    T_read = again.wobjs["wobjPlate"].T_uframe_oframe
    assert np.allclose(T_read[:3, 3], T_new[:3, 3], atol=1e-7)  # 1e-7 m
    assert _angle(T_read[:3, :3], T_new[:3, :3]) < 1e-7  # rad
    _same_module_but_oframe(touch, again, "wobjPlate")

    # Both the input and the output pass the RAPID checker.
    for checked in (TOUCH, path):
        result = _rapidcheck(checked, tmp_path)
        assert result.returncode == 0, result.stdout + result.stderr


def test_the_checker_rejects_a_broken_module(tmp_path: Path) -> None:
    """The checker used above does see a grammar error (so its pass means something)."""
    path = tmp_path / "broken.mod"
    path.write_text(TOUCH.read_text().replace("WaitTime 0.2;", "WaitTime 0.2"))
    result = _rapidcheck(path, tmp_path)
    line = _line(TOUCH.read_text(), "WaitTime 0.2")
    assert result.returncode == 1 and f"{line + 1}:" in result.stdout, result.stdout


def test_with_oframe_keeps_style_and_line_endings(tmp_path: Path) -> None:
    # The drill module: a CONST wobjdata on one line, ", " between values, CRLF line ends.
    crlf = tmp_path / "drill_crlf.mod"
    crlf.write_bytes(DRILL.read_bytes().replace(b"\n", b"\r\n"))
    drill = read_module(crlf)
    assert drill.text.count("\r\n") == DRILL.read_text().count("\n")
    # 200 deg about an axis: the rotation's quaternion with w >= 0 is the one written.
    T_new = _T(list(np.radians(200) * np.array([0.6, 0.0, 0.8])), [-0.25, 0.5, 0.001])
    text = with_oframe(drill, "wobjDrill", T_new)
    start, end = _oframe_span(drill.text, "wobjDrill")
    tail = len(drill.text) - end
    assert text[:start] == drill.text[:start] and text[-tail:] == drill.text[-tail:]
    written = text[start : len(text) - tail]
    numbers = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", written)]
    assert re.fullmatch(r"\[\[[-\d.]+, [-\d.]+, [-\d.]+\], \[([-\d.]+, ){3}[-\d.]+\]\]", written)
    assert numbers[:3] == [-250.0, 500.0, 1.0]  # mm
    assert numbers[3] >= 0.0  # q1 = w >= 0
    # w = cos(100 deg) < 0 for this rotation, so the written quaternion is the negated one.
    half = np.radians(100)
    expected = -np.array([np.cos(half), *(np.sin(half) * np.array([0.6, 0.0, 0.8]))])
    assert np.allclose(numbers[3:], expected, atol=5e-9)

    out = tmp_path / "drill_out.mod"
    out.write_bytes(text.encode())
    again = read_module(out)
    assert again.text.count("\r\n") == drill.text.count("\r\n")
    T_read = again.wobjs["wobjDrill"].T_uframe_oframe
    assert np.allclose(T_read[:3, 3], T_new[:3, 3], atol=1e-7)
    assert _angle(T_read[:3, :3], T_new[:3, :3]) < 1e-7
    _same_module_but_oframe(drill, again, "wobjDrill")

    lf = tmp_path / "drill_lf.mod"
    lf.write_text(text.replace("\r\n", "\n"))
    result = _rapidcheck(lf, tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr


def test_with_oframe_refuses_a_bad_transform_or_work_object(touch: RapidModule) -> None:
    T = np.eye(4)
    T[0, 0] = 2.0
    with pytest.raises(ValueError, match="not a proper rotation"):
        with_oframe(touch, "wobjPlate", T)
    with pytest.raises(ValueError, match=r"\(4, 4\)"):
        with_oframe(touch, "wobjPlate", np.eye(3))
    with pytest.raises(RapidError, match="no wobjdata 'wobjNone'"):
        with_oframe(touch, "wobjNone", np.eye(4))
