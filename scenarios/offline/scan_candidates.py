"""The scan planner's candidate passes (scenarios.offline.scan_plan): their parameters
around the object's upper hemisphere and sides, each kept if the arm follows it at some
table position and the laser clears the object and the cell along it, with the surface the
virtual cell's laser would see of the object and its cell time; where they are planned
(`PlanningCell`), and the error a plan that cannot be made raises (`ScanPlanError`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Kinematics, nominal_T_base_table
from cell.virtual import VirtualCell
from models.robot import LASER
from registration import transform_points
from registration.rigid import invert
from scenarios.offline.scan_passes import ObjectBox, PlannedPass, plan_pass, raster_for
from scenarios.offline.scan_timing import joint_move_s, pass_seconds
from scenarios.offline.settings import Raster, Scan, ScanPass
from scenarios.offline.table_candidates import UnreachablePlanError

#: Laser lines [m] apart along a candidate's sweep in its prediction (the real pass reads
#: one every speed x period, about 1 mm: the prediction needs the surface, not the density).
PREDICT_LINE_SPACING_M = 0.004
#: Every n-th ray of the fan in the prediction.
PREDICT_RAY_STRIDE = 4
#: Samples of a candidate's line checked for collisions in the virtual cell.
COLLISION_SAMPLES = 5


class ScanPlanError(UnreachablePlanError):
    """No plan reaches the goal: a target that no reachable pass constrains."""


@dataclass(frozen=True, eq=False)
class Candidate:
    """One candidate pass: its parameters, its plan (table position, start joints), the
    points (M, 3) and normals (M, 3) the virtual cell predicts it sees, in the model frame,
    and its cell time [s] (sweep, and the moves to it from home and back)."""

    spec: ScanPass
    planned: PlannedPass
    points_model: np.ndarray
    normals_model: np.ndarray
    seconds: float


@dataclass(frozen=True, eq=False)
class PlanningCell:
    """Where passes are planned and predicted: the arm's kinematics (the laser its tool), the
    virtual cell (the nominal model in it at its believed pose, named `object_name`), the
    object's box and pose T_table_object (4, 4) [m], the arm's home joints (6,) [rad] and
    joint speed limits (6,) [rad/s], the laser's data sheet (ray directions (n, 3) in the TCP
    frame, range (min, max) [m], grazing limit [rad]) and the table frame in the arm's base
    at a table position [m] (4, 4)."""

    kin: Kinematics
    cell: VirtualCell
    box: ObjectBox
    T_table_object: np.ndarray
    q_home: np.ndarray
    joint_speed: np.ndarray
    laser: tuple[np.ndarray, tuple[float, float], float]
    T_base_table: Callable[[float], np.ndarray] = nominal_T_base_table
    object_name: str = "object"

    def raster(self, section: Scan) -> Raster | None:
        """The `section`'s raster where the laser is a point (`Scan.raster`), else None."""
        return raster_for(section, self.laser[0])

    def predict(self, planned: PlannedPass) -> tuple[np.ndarray, np.ndarray]:
        """Points (M, 3) and normals (M, 3) in the model frame that the pass' laser sees of
        the object in the virtual cell."""
        dirs_tcp, range_m, incidence = self.laser
        return _predict(
            self.cell, planned, self.T_table_object, dirs_tcp, range_m, incidence,
            self.object_name,
        )  # fmt: skip


def candidate_specs(box: ObjectBox, section: Scan) -> tuple[ScanPass, ...]:
    """The candidate passes' parameters: from above at three aims across the object, and
    tilted at the planner's tilts from every heading, aimed at the object's centre and at its
    near side; each at the scan's stand-off and at the planner's other stand-offs."""
    half = float(max(box.half[0], box.half[1]))
    plan = section.planning
    standoffs: tuple[float | None, ...] = (
        None,
        *(round(section.standoff_m + d, 4) for d in plan.extra_standoffs_m),
    )
    specs = []
    for standoff in standoffs:
        specs += [
            ScanPass(tilt_deg=0.0, heading_deg=h, offset_m=round(f * half, 4), standoff_m=standoff)
            for h in (0.0, 90.0)
            for f in (-0.5, 0.0, 0.5)
        ]
        for tilt in plan.tilts_deg:
            if tilt == 0.0:
                continue
            for h in plan.headings_deg:
                for f in (-0.5, 0.0):
                    specs.append(
                        ScanPass(
                            tilt_deg=tilt, heading_deg=h, offset_m=round(f * half, 4),
                            standoff_m=standoff,
                        )
                    )  # fmt: skip
    return tuple(s for s in specs if s.standoff_m is None or s.standoff_m > 0.05)


def _predict(
    cell: VirtualCell,
    planned: PlannedPass,
    T_table_object: np.ndarray,
    dirs_tcp: np.ndarray,
    range_m: tuple[float, float],
    max_incidence_rad: float,
    object_name: str,
) -> tuple[np.ndarray, np.ndarray]:
    """Points (M, 3) and normals (M, 3) in the model frame that the pass' laser sees of the
    object in the virtual cell: every PREDICT_RAY_STRIDE-th ray of a line laser's fan, every
    raster_stride-th line of a point laser's raster, a reading every PREDICT_LINE_SPACING_M
    along each line."""
    cell.set_table(planned.table_position_m)
    T_world_table = cell.T_world_site("table_top")
    R = T_world_table[:3, :3] @ planned.T_table_start[:3, :3]
    dirs = dirs_tcp[::PREDICT_RAY_STRIDE] @ R.T
    cos_max = np.cos(max_incidence_rad)
    points, normals = [], []
    for start, end in planned.lines()[:: raster_stride(planned)]:
        p0, p1 = start[:3, 3], end[:3, 3]
        n_lines = max(2, int(np.ceil(np.linalg.norm(p1 - p0) / PREDICT_LINE_SPACING_M)) + 1)
        for s in np.linspace(0.0, 1.0, n_lines):
            origin = T_world_table[:3, :3] @ (p0 + s * (p1 - p0)) + T_world_table[:3, 3]
            dist, normal, name = cell.cast(origin, dirs, range_m[1])
            ok = (name == object_name) & (dist >= range_m[0]) & (dist <= range_m[1])
            ok &= -np.einsum("ij,ij->i", normal, dirs) >= cos_max
            points.append(origin + dist[ok, None] * dirs[ok])
            normals.append(normal[ok])
    T_object_world = invert(T_world_table @ T_table_object)
    p = transform_points(T_object_world, np.concatenate(points))
    n = np.concatenate(normals) @ T_object_world[:3, :3].T
    return p, n


def raster_stride(planned: PlannedPass) -> int:
    """Every how many lines of the pass' raster its prediction casts: lines at least
    PREDICT_LINE_SPACING_M apart (1 for a line laser's pass)."""
    if not planned.raster_m:
        return 1
    return max(1, round(PREDICT_LINE_SPACING_M / planned.raster_m[0]))


def _clear(
    cell: VirtualCell,
    kin: Kinematics,
    planned: PlannedPass,
    T_base_table: Callable[[float], np.ndarray],
    margin_m: float,
) -> bool:
    """Whether the arm with the laser follows the pass' line (a raster's first and last
    lines) clear of everything by `margin_m` [m] in the virtual cell (checked at
    COLLISION_SAMPLES points of each)."""
    cell.set_tool("laser")
    cell.set_table(planned.table_position_m)
    T_base = T_base_table(planned.table_position_m)
    q = planned.q_start
    lines = planned.lines()
    for start, end in lines[:: max(1, len(lines) - 1)]:
        p0, p1 = start[:3, 3], end[:3, 3]
        for s in np.linspace(0.0, 1.0, COLLISION_SAMPLES):
            T = start.copy()
            T[:3, 3] = p0 + s * (p1 - p0)
            r = kin.ik(T_base @ T, q, LASER.T_tool_tcp, extra_seeds=0)
            if not r.success:
                return False
            q = r.q
            cell.set_joints(q)
            if cell.contacts(margin_m):
                return False
    return True


def candidates(
    where: PlanningCell, section: Scan, margin_m: float = 0.01
) -> tuple[tuple[Candidate, ...], int]:
    """The reachable candidates whose line clears the cell by `margin_m` [m], with their
    predicted points, and how many were tried."""
    kin, cell, q_home = where.kin, where.cell, where.q_home
    raster = where.raster(section)
    found = []
    specs = candidate_specs(where.box, section)
    for i, spec in enumerate(specs):
        try:
            planned = plan_pass(
                kin, where.box, section, spec, i, q_home, where.T_base_table, raster=raster
            )
        except UnreachablePlanError:
            continue
        if not _clear(cell, kin, planned, where.T_base_table, margin_m):
            continue
        p, n = where.predict(planned)
        if len(p) < 50:
            continue
        # Its own time and the arm's turn to it from home and back: what adding it costs.
        seconds = pass_seconds(planned, section) + 2.0 * joint_move_s(
            q_home, planned.q_start, where.joint_speed
        )
        found.append(Candidate(spec, planned, p, n, seconds))
    return tuple(found), len(specs)


#: The object's points a plan must be predicted to see, over those the match requires
#: (`Scan.min_points`): the prediction's own scatter (about 10 % on the shipped jobs) and a
#: real scan's dropouts.
POINTS_MARGIN = 1.2


def predicted_object_points(
    seen: list[np.ndarray] | tuple[np.ndarray, ...],
    section: Scan,
    passes: list[PlannedPass] | tuple[PlannedPass, ...],
) -> int:
    """How many of the object's points a scan of `passes` whose predictions saw `seen` (each
    (M_k, 3)) reads: the prediction's every PREDICT_RAY_STRIDE-th ray (a raster's every
    raster_stride-th line) and a reading every PREDICT_LINE_SPACING_M, scaled to every ray
    (every line) and a reading every speed x period."""
    lines = PREDICT_LINE_SPACING_M / (section.speed_m_s * section.period_s)
    strides = [raster_stride(p) if p.raster_m else PREDICT_RAY_STRIDE for p in passes]
    return int(sum(len(p) * k for p, k in zip(seen, strides, strict=True)) * lines)
