"""The RAPID module of one move, as the client has a controller run it: a joint move
(MoveAbsJ, the table as external axis A) or a straight move (MoveL) of the TCP of the tool in
hand, in the base frame (wobj0).

Every module is named `MODULE` and loaded over the one before it. Its main calls the helper
module's TcStream first (scenarios.irc5.helper_module: moving the program pointer to main
resets EGM, whose stream carries the encoders and the beam). Targets are written for the
controller's own arm, which is its nominal one (an IRC5 without the absolute-accuracy
option): the client solves a target with the arm it moves with (the calibrated one, once it is
calibrated) and writes the joints that solution has, or the pose the nominal arm puts there
with their confdata, so the controller arrives at those joints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.controller import SETTLE_S
from cell.kinematics import Kinematics
from scenarios.irc5.helper_module import STREAM_PROC
from scenarios.rapid.rapid_text import (
    configuration,
    pose_text,
    rapid_identifier,
    rapid_number,
    tooldata_text,
)

#: The module's name on the controller.
MODULE = "TcMove"
#: The stoppointdata of a stop point that stands its own time.
STOP = "tcStop"
_UNUSED = "9E+09"
#: A speeddata's external axes' speeds: not limiting [mm/s, deg/s].
_EXTERNAL = "5000, 1000"
#: Where no speed limits [mm/s] or [deg/s].
_UNLIMITED = 1.0e4


@dataclass(frozen=True)
class Tool:
    """The tool the move carries: its name in the cell and its TCP in the flange frame
    T_flange_tcp (4, 4) [m] (a program's tooldata; the nominal one if not told), or the
    flange (name None: tool0)."""

    name: str | None
    T_flange_tcp: np.ndarray

    @property
    def declaration(self) -> str:
        """The module's tooldata declaration line ("" for tool0)."""
        if self.name is None:
            return ""
        return f"  {tooldata_text(self.name, self.T_flange_tcp)}\n"

    @property
    def rapid_name(self) -> str:
        return "tool0" if self.name is None else rapid_identifier(self.name, "t")


def _speed(v_tcp_mm_s: float, v_ori_deg_s: float) -> str:
    v_tcp, v_ori = (min(v, _UNLIMITED) for v in (v_tcp_mm_s, v_ori_deg_s))
    return f"[{rapid_number(v_tcp)}, {rapid_number(v_ori)}, {_EXTERNAL}]"


def _stands_own_time(settle_s: float) -> bool:
    """Whether a stop point settles another time than the controller's own (SETTLE_S)."""
    return settle_s > 0.0 and abs(settle_s - SETTLE_S) >= 1e-9


def _zone(settle_s: float) -> str:
    """A stop point if the move settles, else fly-by (z0). A stop point is `fine` where the
    settling asked is the controller's own (SETTLE_S), else `fine \\Inpos:=STOP`: the arm
    stands `settle_s` still there (see `_stop_declaration`)."""
    if settle_s <= 0.0:
        return "z0"
    return f"fine \\Inpos:={STOP}" if _stands_own_time(settle_s) else "fine"


def _supervision(supervised: bool) -> str:
    """The line that switches the motion supervision off for the module's move ("" if it
    watches: moving the program pointer to main switches it on again)."""
    return "" if supervised else "    MotionSup \\Off;\n"


def _stop_declaration(settle_s: float) -> str:
    """The module's stoppointdata line where its stop point stands its own time: of type
    stoptime, the arm standing still `settle_s` [s] before the program goes on ("" where the
    zone needs none)."""
    if not _stands_own_time(settle_s):
        return ""
    return (
        f"  CONST stoppointdata {STOP} := "
        f'[stoptime, FALSE, [0, 0, 0, 0], {rapid_number(settle_s)}, 0, "", 0, 0];\n'
    )


def joint_speed(
    kinematics: Kinematics,
    q_from: np.ndarray,
    q_to: np.ndarray,
    T_flange_tcp: np.ndarray,
    fraction: float,
    joint_speed_rad_s: np.ndarray,
) -> tuple[float, float]:
    """The speeddata (v_tcp [mm/s], v_ori [deg/s]) that makes a controller run the joint move
    from q_from to q_to (6,) [rad] at `fraction` of the joints' speed limits: the TCP's path
    length and turn over the time the slowest joint takes at that fraction."""
    dq = np.asarray(q_to, dtype=float) - np.asarray(q_from, dtype=float)
    t_unit = float(np.max(np.abs(dq) / joint_speed_rad_s))
    if t_unit <= 0.0 or fraction >= 1.0:
        return _UNLIMITED, _UNLIMITED
    steps = np.linspace(0.0, 1.0, 9)
    points = np.array([(kinematics.fk(q_from + s * dq) @ T_flange_tcp)[:3, 3] for s in steps])
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    R0 = (kinematics.fk(q_from) @ T_flange_tcp)[:3, :3]
    R1 = (kinematics.fk(q_to) @ T_flange_tcp)[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R0.T @ R1) - 1.0) / 2.0, -1.0, 1.0)))
    t = t_unit / fraction
    v_tcp = length / t * 1e3 if length > 1e-9 else _UNLIMITED
    v_ori = float(np.degrees(angle / t)) if angle > 1e-9 else _UNLIMITED
    return v_tcp, v_ori


def joint_move(
    q: np.ndarray,
    table_m: float | None,
    speed: tuple[float, float],
    settle_s: float,
    tool: Tool,
    supervised: bool = True,
) -> str:
    """The module of a MoveAbsJ to `q` (6,) [rad] with the table at `table_m` [m] (None: where
    it is), at `speed` (v_tcp [mm/s], v_ori [deg/s]), the motion supervision off if not
    `supervised`."""
    joints = ", ".join(rapid_number(v) for v in np.degrees(q))
    table = _UNUSED if table_m is None else rapid_number(table_m * 1e3)
    external = ", ".join([table] + [_UNUSED] * 5)
    return (
        f"MODULE {MODULE}\n"
        f"  CONST jointtarget jTo := [[{joints}],[{external}]];\n"
        f"{tool.declaration}"
        f"{_stop_declaration(settle_s)}"
        "  PROC main()\n"
        f"    {STREAM_PROC};\n"
        f"{_supervision(supervised)}"
        f"    MoveAbsJ jTo, {_speed(*speed)}, {_zone(settle_s)}, {tool.rapid_name};\n"
        "  ENDPROC\n"
        "ENDMODULE\n"
    )


def linear_move(
    nominal: Kinematics,
    q_end: np.ndarray,
    tool: Tool,
    speed_m_s: float,
    angular_speed_rad_s: float,
    settle_s: float,
    target: str = "pTo",
    supervised: bool = True,
) -> str:
    """The module of a MoveL of the tool's TCP to where the joints `q_end` (6,) [rad] put it on
    the controller's `nominal` arm (with their confdata), in the base frame, named `target`,
    the motion supervision off if not `supervised`."""
    T_base_tcp = nominal.fk(q_end) @ tool.T_flange_tcp
    cf1, cf4, cf6, cfx = configuration(nominal, q_end)
    external = ", ".join([_UNUSED] * 6)
    speed = _speed(speed_m_s * 1e3, float(np.degrees(angular_speed_rad_s)))
    return (
        f"MODULE {MODULE}\n"
        f"  CONST robtarget {target} := "
        f"{pose_text(T_base_tcp)[:-1]},[{cf1},{cf4},{cf6},{cfx}],[{external}]];\n"
        f"{tool.declaration}"
        f"{_stop_declaration(settle_s)}"
        "  PROC main()\n"
        f"    {STREAM_PROC};\n"
        f"{_supervision(supervised)}"
        f"    MoveL {target}, {speed}, {_zone(settle_s)}, {tool.rapid_name};\n"
        "  ENDPROC\n"
        "ENDMODULE\n"
    )
