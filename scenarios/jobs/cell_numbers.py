"""The numbers a user needs to program a job's cell offline, read from the code that builds it
(so the documentation's table of them cannot go stale): the table's frame and travel, where
the part rests on it and the work object that describes it, the tools' data, the rack and the
TCP check's beam, the calibration's spheres, and the arm's home. `twincell author JOB
--numbers` prints them; docs/reference/cell-numbers.md holds them for the shipped cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import nominal_T_base_table
from cell.robots import BUILTIN
from models.robot import TABLE_HALF, TABLE_TRAVEL, TOOLS
from models.robot.tools import BEAM_OFFSET, SLOT_HEIGHT, SLOT_X
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.job_plan import job_robot
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.operations import WOBJ_TOLERANCE_DEG, WOBJ_TOLERANCE_M, virtual_model
from scenarios.offline.tcp_check import POINTERS
from scenarios.rapid.oframe import pose_text
from scenarios.rapid.rapid_text import tooldata_text


@dataclass(frozen=True)
class CellNumber:
    """One number of the cell: what it is, its value as a user writes it (mm, degrees, RAPID
    data), and where it comes from (the configuration key that sets it, or the cell's
    design)."""

    quantity: str
    value: str
    source: str


def _mm(values: np.ndarray | tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{v * 1e3:g}" for v in values) + "] mm"


def _table_and_part(config: JobConfig) -> list[CellNumber]:
    settings = config.planning()
    obj = config.cell.object
    virtual = virtual_model(obj.model, obj.units, None, config.operations.kind, config.seed)
    T_table_object = nominal_pose(settings.placement, virtual.mesh.vertices)
    T_base_table = nominal_T_base_table(0.0)
    placement = ", ".join(f"{k}: {v}" for k, v in settings.placement.model_dump().items())
    extents = (T_table_object[:3, :3] @ virtual.mesh.vertices.T).T + T_table_object[:3, 3]
    return [
        CellNumber(
            "table frame (top surface's centre) in the cell frame, table at 0",
            _mm(T_base_table[:3, 3]) + ", axes as the base's",
            "cell design",
        ),
        CellNumber(
            "table's travel along the base's y (external axis A)", _mm(TABLE_TRAVEL), "cell design"
        ),
        CellNumber(
            "table top's size (x by y)", _mm(tuple(2 * h for h in TABLE_HALF[:2])), "cell design"
        ),
        CellNumber("the part's nominal placement on the table", placement, "cell.object.placement"),
        CellNumber(
            "the part's extents in the table frame (x, y, z ranges)",
            "; ".join(
                f"{a} {lo * 1e3:.1f} to {hi * 1e3:.1f} mm"
                for a, lo, hi in zip("xyz", extents.min(axis=0), extents.max(axis=0), strict=True)
            ),
            "cell.object.model, cell.object.placement",
        ),
        CellNumber(
            "work object (RAPID): uframe on the part's nominal pose (table at 0), oframe identity",
            f'[FALSE,TRUE,"",{pose_text(T_base_table @ T_table_object)},[[0,0,0],[1,0,0,0]]]',
            "cell.object.placement (twincell author writes it)",
        ),
        CellNumber(
            "a program's work object must lie this close to it",
            f"{WOBJ_TOLERANCE_M * 1e3:g} mm, {WOBJ_TOLERANCE_DEG:g} deg",
            "cell design",
        ),
    ]


def _tools(config: JobConfig) -> list[CellNumber]:
    rack = np.asarray(config.cell.rack_xyz, dtype=float)
    rows = [
        CellNumber(
            f"tooldata of the {tool.name} (TCP, mass [kg], centre of gravity)",
            tooldata_text(tool.name).split(":= ")[1].rstrip(";"),
            "cell design",
        )
        for tool in TOOLS
    ]
    rows += [
        CellNumber(
            f"the {name}'s tip ball radius (its TCP is the ball's centre)",
            f"{radius * 1e3:g} mm",
            "cell design",
        )
        for name, (radius, _) in POINTERS.items()
    ]
    slots = [rack + np.array([x, 0.0, SLOT_HEIGHT]) for x in SLOT_X]
    rows += [
        CellNumber("the tool rack's frame in the cell frame", _mm(rack), "cell.rack_xyz"),
        CellNumber(
            "the rack's slots (" + ", ".join(t.name for t in TOOLS) + ")",
            "; ".join(_mm(s) for s in slots),
            "cell.rack_xyz",
        ),
        CellNumber(
            "the TCP check's light beam (centre)",
            _mm(rack + np.array(BEAM_OFFSET)),
            "cell.rack_xyz",
        ),
    ]
    return rows


def cell_numbers(config: JobConfig) -> tuple[CellNumber, ...]:
    """The numbers of `config`'s cell (see the module's docstring)."""
    rows = _table_and_part(config) + _tools(config)
    if config.calibration.enabled:
        rows.append(
            CellNumber(
                f"the calibration's sphere centres in the table frame "
                f"(radius {DEFAULT_ARTIFACT.radius_m * 1e3:g} mm)",
                "; ".join(_mm(c) for c in DEFAULT_ARTIFACT.centres_table),
                "cell design (calibration.enabled)",
            )
        )
    robot = config.cell.robot
    if robot.home_deg is not None:
        home = "[" + ", ".join(f"{v:g}" for v in robot.home_deg) + "] deg"
    elif robot.model in BUILTIN:
        home = "[" + ", ".join(f"{v:.3f}" for v in np.degrees(job_robot(robot).q_home)) + "] deg"
    else:
        home = "chosen by the job in the virtual cell (twincell run says which)"
    rows += [
        CellNumber("the arm", robot.model, "cell.robot.model"),
        CellNumber(
            "the arm's base in the cell frame (RAPID's base frame where it is the cell's)",
            f"{_mm(robot.mount_xyz or (0.0, 0.0, 0.0))}, "
            f"turned {robot.mount_yaw_deg:g} deg about z",
            "cell.robot.mount_xyz, mount_yaw_deg",
        ),
        CellNumber("the arm's home (every job starts and ends there)", home, "cell.robot.home_deg"),
    ]
    return tuple(rows)


def numbers_markdown(numbers: tuple[CellNumber, ...]) -> str:
    """The numbers as a Markdown table."""
    lines = ["| quantity | value | set by |", "|---|---|---|"]
    lines += [f"| {n.quantity} | `{n.value}` | {n.source} |" for n in numbers]
    return "\n".join(lines) + "\n"
