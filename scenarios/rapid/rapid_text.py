"""RAPID's literals as this project writes them: numbers, poses, confdata, names and the
cell's tooldata. Millimetres and scalar-first quaternions (q1 = w) at this edge only."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from cell.kinematics import Kinematics
from models.robot import TOOLS
from registration.rigid import R_to_quat_wxyz

#: RAPID's "unused" for an external axis.
UNUSED = "9E+09"


def rapid_number(x: float) -> str:
    """`x` as a RAPID literal with at most 4 decimals (a millimetre's tenth of a micrometre)."""
    text = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def pose_text(T: np.ndarray) -> str:
    """The pose T (4, 4) [m] as RAPID's [[x, y, z], [q1, q2, q3, q4]] (mm, w first)."""
    p = T[:3, 3] * 1e3
    q = R_to_quat_wxyz(T[:3, :3])
    return f"[[{', '.join(rapid_number(v) for v in p)}],[{', '.join(f'{v:.8f}' for v in q)}]]"


def _quadrant(angle: float) -> int:
    return int(np.floor(angle / (np.pi / 2)))


def configuration(kin: Kinematics, q: np.ndarray) -> tuple[int, int, int, int]:
    """ABB configuration data (cf1, cf4, cf6, cfx) of joints q (6,) [rad]: quadrants of axes
    1, 4, 6, and cfx = 4 * (wrist centre behind axis 1) + 2 * (below the lower arm) +
    (axis 5 negative)."""
    model, data = kin.model, kin.model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
    p2, p3, wc = (np.array(data.oMi[j].translation) for j in (2, 3, 5))
    c, s = np.cos(q[0]), np.sin(q[0])

    def plane(p: np.ndarray) -> np.ndarray:  # (reach along axis 1's heading, height)
        return np.array([c * p[0] + s * p[1], p[2]])

    behind = plane(wc)[0] < 0.0
    lower = plane(p3) - plane(p2)
    w = plane(wc) - plane(p2)
    below = lower[0] * w[1] - lower[1] * w[0] > 0.0
    cfx = 4 * int(behind) + 2 * int(below) + int(q[4] < 0.0)
    return _quadrant(q[0]), _quadrant(q[3]), _quadrant(q[5]), cfx


def rapid_identifier(name: str, prefix: str) -> str:
    """A RAPID name for `name`: `prefix` (e.g. "p" for a robtarget, "t" for a tooldata), the
    name's first letter upper-cased, any character RAPID does not allow an underscore, 32
    characters at most."""
    body = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return f"{prefix}{body[:1].upper()}{body[1:]}"[:32]


def tooldata_text(tool: str, T_flange_tcp: np.ndarray | None = None) -> str:
    """The RAPID declaration of the cell's `tool` (its TCP in the flange frame: the nominal
    one, or `T_flange_tcp` (4, 4); mass, centre of gravity half way to the TCP):
    `PERS tooldata tName := [...];`."""
    spec = next(t for t in TOOLS if t.name == tool)
    T = spec.T_tool_tcp if T_flange_tcp is None else T_flange_tcp
    cog = rapid_number(spec.p_tool_tcp[2] * 1e3 / 2)
    return (
        f"PERS tooldata {rapid_identifier(tool, 't')} := [TRUE,{pose_text(T)},"
        f"[{rapid_number(spec.mass)},[0,0,{cog}],[1,0,0,0],0,0,0]];"
    )
