"""The virtual cell a job is checked in (the program's pre-motion check, the scan's plan,
the calibration's views), and what the object's placement asks of the arm's clearance there:
how far the object may be from its nominal pose, and whether the arm keeps that clear of it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell import FixedMesh, FixedPrimitive
from cell.robots import Robot
from cell.virtual import EXACT_BAND_M, VirtualCell
from models.model import ObjectModel
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.settings import FixtureTolerance


def job_virtual_cell(
    robot: Robot,
    rack_xyz: tuple[float, float, float],
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    calibrates: bool = False,
    name: str = "object",
    exact_band_m: float = EXACT_BAND_M,
) -> VirtualCell:
    """The virtual cell a job's program is checked in: the job's arm (nominal) and rack at
    `rack_xyz` [m], the virtual model `virtual` (its convex pieces for contact) at the pose
    T_table_object (4, 4) the program was corrected with, named `name`, and the calibration
    spheres at their design places if the job `calibrates`; near the object (within
    `exact_band_m` [m] of its pieces) the arm and tool are measured against its own mesh
    (cell.virtual)."""
    pieces = tuple(p.vertices for p in virtual.convex_pieces)
    fixtures: tuple[FixedMesh | FixedPrimitive, ...] = (
        FixedMesh(name, virtual.mesh.vertices, virtual.mesh.faces, T_table_object, pieces),
    )
    if calibrates:
        fixtures = (*fixtures, *DEFAULT_ARTIFACT.fixtures())
    return VirtualCell.of(robot, rack_xyz, fixtures, exact_band_m)


def placement_uncertainty_m(tolerance: FixtureTolerance, lift_m: float, radius_m: float) -> float:
    """How far [m] a point of an object of `radius_m` (its footprint about its centre) may
    be from where its nominal pose puts it, given the fixture's `tolerance` (sideways, about
    the vertical, tilted) and its nominal lift `lift_m` [m] off the table."""
    return float(
        np.hypot(tolerance.xy_m, tolerance.xy_m)
        + 2.0 * radius_m * np.sin(np.deg2rad(tolerance.yaw_deg) / 2.0)
        + radius_m * np.sin(np.deg2rad(tolerance.tilt_deg))
        + lift_m
    )


def clear_of(
    cell: VirtualCell, tool: str, name: str, margin_m: float
) -> Callable[[np.ndarray, float], bool]:
    """Whether the arm with `tool` at joints q (6,), the table at a position [m], keeps
    `margin_m` [m] from the object `name` in the virtual `cell` (the object at its nominal
    pose; the margin holds how far the real one may be from it)."""

    def clear(q: np.ndarray, table_position_m: float) -> bool:
        cell.set_table(table_position_m)
        cell.set_tool(tool)
        cell.set_joints(q)
        return not cell.contacts(margin_m, other=name)

    return clear
