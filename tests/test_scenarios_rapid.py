"""RAPID export: syntax, millimetres, scalar-first quaternions, the correction in oframe."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cell import nominal_kinematics, nominal_T_base_table
from scenarios.program.program_types import OfflineProgram, Operation, PlannedOperation
from scenarios.rapid.rapid_text import configuration
from scenarios.rapid.writer import program_module

_NUM = r"[-+0-9.Ee]+"


def _T(rotvec: list[float], p: list[float]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = p
    return T


def _R_from_wxyz(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z), written out (textbook formula)."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(text: str) -> np.ndarray:
    """(4, 4) [m] of a RAPID pose text '[[x,y,z],[q1,q2,q3,q4]]' in mm."""
    values = [float(v) for v in re.findall(_NUM, text)]
    T = np.eye(4)
    T[:3, 3] = np.array(values[:3]) * 1e-3
    T[:3, :3] = _R_from_wxyz(np.array(values[3:7]))
    return T


@pytest.fixture(scope="module")
def program() -> tuple[OfflineProgram, np.ndarray, str]:
    T_table_nominal = _T([0, 0, np.pi], [0.01, -0.02, 0.11])
    T_table_object = _T([0.01, -0.02, np.pi + 0.2], [0.025, 0.0, 0.112])  # the measured pose
    table = 0.1
    ops = []
    for k, (rv, p) in enumerate(
        [([np.pi, 0, 0], [0.03, -0.02, 0.07]), ([2.8, 0.3, 0.1], [-0.05, 0.03, 0.06])]
    ):
        T_touch = _T(rv, p)
        op = Operation(f"hole_{k}", T_touch, 0.05)
        T_app = op.T_object_approach
        T_base_object = nominal_T_base_table(table) @ T_table_object
        q = np.array([0.1 * k, 0.2, -0.1, 0.3, -0.4 + k, 0.5])
        ops.append(
            PlannedOperation(
                op, 0.0, T_touch, T_app, T_base_object @ T_app, T_base_object @ T_touch, q, q
            )
        )
    prog = OfflineProgram("screwer", table, T_table_object, tuple(ops))
    text = program_module(prog, nominal_kinematics(), T_table_nominal)
    return prog, T_table_nominal, text


def test_module_structure_and_syntax(program: tuple[OfflineProgram, np.ndarray, str]) -> None:
    _, _, text = program
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    assert lines[0] == "MODULE TwincellProgram" and lines[-1] == "ENDMODULE"
    assert "PROC main()" in lines and "ENDPROC" in lines
    declared = set(re.findall(r"CONST robtarget (\w+) :=", text))
    assert len(declared) == 4
    statements = [
        ln for ln in lines if not ln.startswith(("!", "MODULE", "ENDMODULE", "PROC", "ENDPROC"))
    ]
    assert all(ln.endswith(";") for ln in statements)
    moves = re.findall(r"(MoveJ|MoveL) (\w+), (\w+), (\w+), (\w+) \\WObj:=(\w+);", text)
    assert len(moves) == 6  # approach, touch, back for each of 2 operations
    for _kind, target, _speed, _zone, tool, wobj in moves:
        assert target in declared and tool == "tScrewer" and wobj == "wobjObject"
    assert all(len(name) <= 32 for name in declared)
    assert text.count("[") == text.count("]")


def test_targets_in_mm_with_wxyz_and_the_correction_in_oframe(
    program: tuple[OfflineProgram, np.ndarray, str],
) -> None:
    prog, T_table_nominal, text = program
    wobj = re.search(
        r"PERS wobjdata wobjObject := \[FALSE,TRUE,\"\",(\[\[.*?\]\]),(\[\[.*?\]\])\];", text
    )
    assert wobj is not None
    T_base_uframe, T_uframe_oframe = _pose(wobj.group(1)), _pose(wobj.group(2))
    # uframe is the fixture: the nominal object pose at the program's table position.
    expected_uframe = nominal_T_base_table(prog.table_position_m) @ T_table_nominal
    assert np.allclose(T_base_uframe, expected_uframe, atol=1e-6)
    # oframe carries the correction: uframe @ oframe is the measured object pose.
    assert np.allclose(T_base_uframe @ T_uframe_oframe, prog.T_base_object, atol=1e-6)
    for planned in prog.operations:
        name = "pHole_" + planned.operation.name.split("_")[1]
        for suffix, T_base in (("Touch", planned.T_base_touch), ("App", planned.T_base_approach)):
            m = re.search(
                rf"CONST robtarget {name}{suffix} := "
                r"\[(\[.*?\],\[.*?\]),\[([-0-9,]+)\],\[(.*?)\]\];",
                text,
            )
            assert m is not None, name + suffix
            T_object = _pose(m.group(1))
            # 0.1 um and 1e-7 rad: the printed precision of mm and of the quaternion.
            assert np.allclose(
                (T_base_uframe @ T_uframe_oframe @ T_object)[:3, 3], T_base[:3, 3], atol=1e-7
            )
            assert np.allclose(T_base_uframe @ T_uframe_oframe @ T_object, T_base, atol=1e-6)
            eax = m.group(3).split(",")
            assert float(eax[0]) == pytest.approx(prog.table_position_m * 1e3)
            assert eax[1:] == ["9E+09"] * 5
    tool = re.search(r"PERS tooldata tScrewer := \[TRUE,(\[\[.*?\]\]),", text)
    assert tool is not None
    assert np.allclose(_pose(tool.group(1))[:3, 3], [0.0, 0.0, 0.2])  # screwer TCP 200 mm


def test_configuration_data() -> None:
    kin = nominal_kinematics()
    # ABB: the calibration (zero) position has cfx 0 and every quadrant 0.
    assert configuration(kin, np.zeros(6)) == (0, 0, 0, 0)
    q = np.array(np.deg2rad([100.0, 0.0, 0.0, -10.0, -30.0, 200.0]))
    cf1, cf4, cf6, cfx = configuration(kin, q)
    assert (cf1, cf4, cf6) == (1, -1, 2)  # 100 deg: quadrant 1; -10: -1; 200: 2
    assert cfx & 1 == 1  # axis 5 negative
    # Arm bent backwards over the base (axis 2 at -90 deg, axis 3 up): wrist behind axis 1.
    q_back = np.array(np.deg2rad([0.0, -90.0, 60.0, 0.0, 30.0, 0.0]))
    assert configuration(kin, q_back)[3] & 4 == 4
