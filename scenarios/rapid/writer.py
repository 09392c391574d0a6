"""ABB RAPID export of a corrected offline program (program.mod).

Millimetres and scalar-first quaternions (q1 = w) at this edge only. The work object keeps
the fixture in `uframe` (the object's NOMINAL pose on the table at the program's table
position) and puts the registration correction in `oframe`; the robtargets stay as they were
programmed on the virtual model (tool poses in the object frame). So
uframe @ oframe @ robtarget = the corrected TCP pose in the base frame. The table is the
external axis eax_a [mm].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.controller import RACK_APPROACH_M, nominal_T_base_table
from cell.kinematics import Kinematics
from models.robot import TOOLS
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.rapid_text import (
    UNUSED,
    configuration,
    pose_text,
    rapid_identifier,
    rapid_number,
    tooldata_text,
)


@dataclass(frozen=True, eq=False)
class Filter:
    """What filtering a program needs (RoboDK's "program filtering"): the calibrated arm
    (motor angles in) and the nominal one the controller computes with, the tool's rack
    slot (4, 4) and the arm's home (6,) [rad] (a controller without absolute accuracy fetches
    the tool with its nominal arm, so the tool sits where that fetch puts it)."""

    calibrated: Kinematics
    nominal: Kinematics
    T_base_slot: np.ndarray
    q_home: np.ndarray

    def T_flange_tcp(self, tool: str) -> np.ndarray:
        """(4, 4) the tool's TCP in the calibrated flange frame as the controller's own fetch
        mounts it: the calibrated tooldata."""
        spec = next(t for t in TOOLS if t.name == tool)
        above = self.T_base_slot.copy()
        above[2, 3] += RACK_APPROACH_M
        bare = self.nominal.for_tool(None)
        q_lock = bare.solve(self.T_base_slot, bare.solve(above, self.q_home))
        T_flange_tool = np.linalg.solve(self.calibrated.for_tool(None).fk(q_lock), self.T_base_slot)
        return T_flange_tool @ spec.T_tool_tcp

    def targets(
        self, program: OfflineProgram, T_flange_tcp: np.ndarray
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Per operation: the approach and touch poses (4, 4) to write, for the controller's
        nominal arm with the tooldata `T_flange_tcp`, and their joints (6,) [rad]: the
        calibrated arm's solution of the corrected target, and the nominal arm's pose of the
        TCP at those joints."""
        kin = self.calibrated.for_tool(program.tool)
        nominal = self.nominal.for_tool(program.tool)
        out = []
        for planned in program.operations:
            q_app = kin.solve(planned.T_base_approach, planned.q_approach, T_flange_tcp)
            q_touch = kin.solve(planned.T_base_touch, q_app, T_flange_tcp)
            out.append(
                (
                    nominal.fk(q_app) @ T_flange_tcp,
                    q_app,
                    nominal.fk(q_touch) @ T_flange_tcp,
                    q_touch,
                )
            )
        return out


#: The exported program's module name.
PROGRAM_MODULE = "TwincellProgram"


def program_module(
    program: OfflineProgram,
    kin: Kinematics,
    T_table_object_nominal: np.ndarray,
    module: str = PROGRAM_MODULE,
    touch_speed_m_s: float = 0.02,
    filtered: Filter | None = None,
) -> str:
    """The RAPID module text of `program`: tooldata, wobjdata (uframe = nominal fixture,
    oframe = correction), robtargets, MoveJ to each approach, MoveL to the touch and back.

    `filtered` None (compensation "nominal"): the robtargets are the tool poses as
    programmed on the virtual model and the tooldata the drawing's; a controller without
    absolute accuracy misses them by its arm's own error. With `filtered` (compensation
    "filtered"): each robtarget is the pose the nominal arm would have at the joints the
    calibrated arm needs for the corrected target, with the calibrated tooldata, so that the
    controller, computing with its nominal arm, goes to those very joints (RoboDK's program
    filtering). Robtargets rather than MoveAbsJ jointtargets: the moves stay MoveL where the
    program had them (straight, at the programmed speed, through zones), the configuration
    data still pick the branch, and the points can be touched up like any other. `kin` gives
    the configuration data (the controller's nominal arm)."""
    T_base_uframe = nominal_T_base_table(program.table_position_m) @ T_table_object_nominal
    T_uframe_oframe = np.linalg.inv(T_table_object_nominal) @ program.T_table_object
    T_base_wobj = T_base_uframe @ T_uframe_oframe
    tool = rapid_identifier(program.tool, "t")
    wobj = "wobjObject"
    eax = f"[{rapid_number(program.table_position_m * 1e3)},{','.join([UNUSED] * 5)}]"
    T_tcp = None if filtered is None else filtered.T_flange_tcp(program.tool)
    if filtered is None:
        written = [
            (p.T_object_approach, p.q_approach, p.T_object_touch, p.q_touch)
            for p in program.operations
        ]
        header = [
            "  ! compensation: nominal",
            "  ! uframe: the object's nominal pose on the table; oframe: the registration's",
            "  ! correction; robtargets: the tool poses as programmed on the virtual model.",
        ]
    else:
        assert T_tcp is not None
        to_wobj = np.linalg.inv(T_base_wobj)
        written = [
            (to_wobj @ T_app, q_app, to_wobj @ T_touch, q_touch)
            for T_app, q_app, T_touch, q_touch in filtered.targets(program, T_tcp)
        ]
        header = [
            "  ! compensation: filtered",
            "  ! uframe: the object's nominal pose on the table; oframe: the registration's",
            "  ! correction; robtargets and tooldata filtered for this cell's calibrated arm:",
            "  ! a controller without absolute accuracy reaches the corrected targets.",
        ]
    lines = [
        f"MODULE {module}",
        "  ! Offline program corrected by 3D surface matching (twincell).",
        "  ! Lengths in mm, quaternions [q1 (w), q2, q3, q4]; table = external axis A [mm].",
        *header,
        f"  {tooldata_text(program.tool, T_tcp)}",
        f'  PERS wobjdata {wobj} := [FALSE,TRUE,"",{pose_text(T_base_uframe)},'
        f"{pose_text(T_uframe_oframe)}];",
        f"  CONST speeddata vTouch := [{rapid_number(touch_speed_m_s * 1e3)},500,5000,1000];",
    ]
    names = []
    for planned, (T_app, q_app, T_touch, q_touch) in zip(program.operations, written, strict=True):
        base = rapid_identifier(planned.operation.name, "p")
        for suffix, T_object, q in (("App", T_app, q_app), ("Touch", T_touch, q_touch)):
            cf = ",".join(str(v) for v in configuration(kin, q))
            target = f"{base}{suffix}"[:32]
            lines.append(f"  CONST robtarget {target} := {pose_text(T_object)[:-1]},[{cf}],{eax}];")
        names.append((f"{base}App"[:32], f"{base}Touch"[:32]))
    lines.append("  PROC main()")
    for app, touch in names:
        lines.append(f"    MoveJ {app}, v500, z10, {tool} \\WObj:={wobj};")
        lines.append(f"    MoveL {touch}, vTouch, fine, {tool} \\WObj:={wobj};")
        lines.append(f"    MoveL {app}, v100, z10, {tool} \\WObj:={wobj};")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
