"""The scan: a plan of straight laser passes made in the virtual cell, executed on the real one.

The plan knows only the virtual model and its NOMINAL place on the table. Points are
reconstructed as a real system does: measured joints, the cell's model (the calibrated arm,
the laser's mounting and scale; the data sheet's without a calibration), laser distances and
the table readout, and kept in the table frame so that passes made at different table
positions share one frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller, Kinematics, LaserReading, nominal_T_base_table, points_in_table_frame
from cell.cell_errors import CellError, UnreachableTargetError
from cell.controller import SETTLE_S
from cell.trajectory import straight_path
from models.robot import LASER, TABLE_TRAVEL
from registration import transform_points
from scenarios.offline.cell_model import CellModel
from scenarios.offline.laser_sheet import single_ray
from scenarios.offline.settings import Raster, Scan, ScanPass
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M, UnreachablePlanError
from scenarios.program.tool_change import change_tool_safely

Progress = Callable[[str], None]
#: Table positions tried, in order, for a pass or an operation that the arm cannot reach [m].
#: Points closer than this to the table top are the table, not the object [m].
TABLE_CLEARANCE_M = 0.003


@dataclass(frozen=True)
class ObjectBox:
    """The object's nominal extent in the table frame: centre (3,) and half sizes (3,) [m],
    and the radius of its footprint about the centre [m]."""

    centre: np.ndarray
    half: np.ndarray
    radius_xy: float

    @classmethod
    def of(cls, vertices_object: np.ndarray, T_table_object: np.ndarray) -> ObjectBox:
        p = transform_points(T_table_object, np.asarray(vertices_object))
        lo, hi = p.min(axis=0), p.max(axis=0)
        centre = (lo + hi) / 2
        radius = float(np.max(np.linalg.norm(p[:, :2] - centre[:2], axis=1)))
        return cls(centre, (hi - lo) / 2, radius)


@dataclass(frozen=True)
class PlannedPass:
    """A straight laser pass: laser TCP poses (4, 4) at its ends in the table frame, the
    table position [m] at which the arm follows it, and the joints (6,) at its start;
    `q_via`: joints (6,) the arm moves through on its way to the start (a transit that would
    otherwise sweep the laser through the object). A point laser's pass is a raster: after
    that first line, one line at each of `raster_m` [m] from it along the laser's x axis
    (across the sweep), each run back the way the one before came (`lines`)."""

    name: str
    T_table_start: np.ndarray
    T_table_end: np.ndarray
    table_position_m: float
    q_start: np.ndarray
    T_base_table: np.ndarray | None = None
    q_via: tuple[np.ndarray, ...] = ()
    raster_m: tuple[float, ...] = ()

    def lines(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        """The pass' straight lines in the order they are run: their (start, end) laser TCP
        poses (4, 4) in the table frame (`raster_lines`)."""
        return raster_lines(self.T_table_start, self.T_table_end, self.raster_m)

    @property
    def T_table_last(self) -> np.ndarray:
        """(4, 4) the laser TCP pose in the table frame where the pass ends."""
        return self.lines()[-1][1]

    def T_base(self, T_table: np.ndarray) -> np.ndarray:
        """(4, 4) the pose T_table (in the table frame) in the base frame at this pass' table
        position (the table frame as planned; default the nominal)."""
        T = self.T_base_table
        return (nominal_T_base_table(self.table_position_m) if T is None else T) @ T_table


@dataclass(frozen=True, eq=False)
class ScanData:
    """The measured scan.

    Attributes:
        points_table: (N, 3) every returned point in the nominal table frame [m].
        line_origins_table: (L, 3) laser origin of each line [m] (nominal kinematics).
        line_index: (N,) the line each point belongs to.
        line_times_s: (L,) controller time of each line [s].
        line_pass: (L,) index of the pass of each line.
        line_q: (L, 6) measured joints of each line [rad].
        seconds: cell time of the scan's motions [s]: from the laser in hand to the end of
            the last pass (the tool change not counted).
    """

    points_table: np.ndarray
    line_origins_table: np.ndarray
    line_index: np.ndarray
    line_times_s: np.ndarray
    line_pass: np.ndarray
    line_q: np.ndarray
    seconds: float = 0.0

    @property
    def lines(self) -> int:
        return len(self.line_origins_table)


def laser_orientation(tilt_rad: float) -> np.ndarray:
    """(3, 3) laser TCP orientation in the table frame: z (the view) down, tilted by
    `tilt_rad` about y towards +x; the fan (x) in the x-z plane; the sweep along y."""
    z = np.array([np.sin(tilt_rad), 0.0, -np.cos(tilt_rad)])
    x = np.array([np.cos(tilt_rad), 0.0, np.sin(tilt_rad)])
    return np.column_stack([x, np.cross(z, x), z])


def raster_lines(
    T_start: np.ndarray, T_end: np.ndarray, raster_m: tuple[float, ...]
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """The (start, end) poses (4, 4) of a raster's lines in the order they are run: the line
    from `T_start` to `T_end`, then one at each of `raster_m` [m] from it along the laser's
    x axis, each run back the way the one before came."""
    out = [(T_start, T_end)]
    x = T_start[:3, 0]
    for k, offset in enumerate(raster_m, start=1):
        a, b = T_start.copy(), T_end.copy()
        a[:3, 3] += offset * x
        b[:3, 3] += offset * x
        out.append((b, a) if k % 2 else (a, b))
    return tuple(out)


def raster_for(section: Scan, directions_tcp: np.ndarray) -> Raster | None:
    """The scan's raster (`Scan.raster`) for a point laser (`single_ray(directions_tcp)`),
    None for a line laser, whose fan covers a pass' width in one line."""
    return section.raster if single_ray(directions_tcp) else None


def raster_offsets(raster: Raster) -> np.ndarray:
    """(n,) the raster's lines' offsets [m] along the laser's x axis from the pass' own
    line: `step_m` apart from -`half_width_m` to +`half_width_m`."""
    n = int(np.floor(2.0 * raster.half_width_m / raster.step_m + 1e-9)) + 1
    return -raster.half_width_m + raster.step_m * np.arange(n)


def _pose(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def line_solution(
    kin: Kinematics,
    T_tcp: np.ndarray,
    T_base_start: np.ndarray,
    T_base_end: np.ndarray,
    q_seed: np.ndarray,
    samples: int = 24,
) -> np.ndarray | None:
    """Joints (6,) at the start of a straight TCP line from which the nominal arm follows
    the whole line without a configuration flip (as the controller's linear move does), or
    None. Checks `samples` points of the line."""
    first = kin.ik(T_base_start, q_seed, T_tcp, extra_seeds=12)
    if not first.success:
        return None
    q = first.q
    for T in straight_path(T_base_start, T_base_end, np.linspace(0.0, 1.0, samples)[1:]):
        r = kin.ik(T, q, T_tcp, extra_seeds=0)
        if not r.success or np.max(np.abs(r.q - q)) > 0.5:
            return None
        q = r.q
    return first.q


def choose_table_position(
    kin: Kinematics,
    T_tcp: np.ndarray,
    T_table_start: np.ndarray,
    T_table_end: np.ndarray,
    q_seed: np.ndarray,
    what: str,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
    positions: tuple[float, ...] = TABLE_CANDIDATES_M,
    raster_m: tuple[float, ...] = (),
) -> tuple[float, np.ndarray]:
    """The first table position of `positions` [m] at which the nominal arm follows the
    straight line between two poses (4, 4) of the table frame with the TCP `T_tcp` (and a
    raster's middle and last lines beside it, `raster_m`: see PlannedPass), and the joints
    (6,) at its start."""
    lo, hi = TABLE_TRAVEL
    lines = raster_lines(T_table_start, T_table_end, raster_m)
    others = lines[1:] if len(lines) <= 3 else (lines[len(lines) // 2], lines[-1])
    for s in positions:
        if not lo <= s <= hi:
            continue
        T_base_table = table(s)
        q = line_solution(
            kin, T_tcp, T_base_table @ T_table_start, T_base_table @ T_table_end, q_seed
        )
        q_line = q
        for a, b in others:
            if q_line is not None:
                q_line = line_solution(kin, T_tcp, T_base_table @ a, T_base_table @ b, q_line)
        if q is not None and q_line is not None:
            return s, q
    raise UnreachablePlanError(f"{what}: no table position in {positions} m lets the arm follow it")


def plan_pass(
    kin: Kinematics,
    box: ObjectBox,
    config: Scan,
    spec: ScanPass,
    index: int,
    q_seed: np.ndarray,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
    positions: tuple[float, ...] = TABLE_CANDIDATES_M,
    raster: Raster | None = None,
) -> PlannedPass:
    """One pass over the object's nominal box (see `ScanPass`), the `index`-th of its plan
    (even: sweeping along +y of its heading, odd: back), at the first table position of
    `positions` [m] at which the arm follows it; a point laser's `raster` of lines across
    it (None: a line laser's single line)."""
    heading = np.deg2rad(spec.heading_deg)
    ch, sh = np.cos(heading), np.sin(heading)
    Rz = np.array([[ch, -sh, 0.0], [sh, ch, 0.0], [0.0, 0.0, 1.0]])
    R = Rz @ laser_orientation(np.deg2rad(spec.tilt_deg))
    view, sweep = R[:, 2], Rz[:, 1]
    reach = float(np.abs(view) @ box.half)  # the box's half depth along the view
    width = float(np.abs(sweep) @ box.half) + config.margin_m
    aim = box.centre + spec.offset_m * Rz[:, 0]
    standoff = config.standoff_m if spec.standoff_m is None else spec.standoff_m
    p_mid = aim - (reach + standoff) * view
    sign = 1.0 if index % 2 == 0 else -1.0
    offsets = raster_offsets(raster) if raster is not None else np.zeros(1)
    p_mid = p_mid + offsets[0] * R[:, 0]  # a raster's first line
    raster_m = tuple(float(o - offsets[0]) for o in offsets[1:])
    T_start = _pose(R, p_mid - sign * width * sweep)
    T_end = _pose(R, p_mid + sign * width * sweep)
    name = f"pass {index + 1} (tilt {spec.tilt_deg:g} deg, heading {spec.heading_deg:g} deg"
    name += "" if spec.standoff_m is None else f", {spec.standoff_m * 1e3:.0f} mm away"
    name += f", {len(offsets)} lines)" if raster is not None else ")"
    s_table, q_start = choose_table_position(
        kin, LASER.T_tool_tcp, T_start, T_end, q_seed, f"scan pass {index + 1}", table,
        positions, raster_m,
    )  # fmt: skip
    return PlannedPass(name, T_start, T_end, s_table, q_start, table(s_table), (), raster_m)


def plan_scan(
    kin: Kinematics,
    box: ObjectBox,
    config: Scan,
    q_seed: np.ndarray,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
    specs: tuple[ScanPass, ...] | None = None,
    raster: Raster | None = None,
) -> tuple[PlannedPass, ...]:
    """The passes `specs` (default the configuration's) over the object's nominal box (see
    `plan_pass`; a point laser's `raster`), alternating sweep direction so that consecutive
    passes join without crossing over the object."""
    passes = []
    for i, spec in enumerate(config.passes if specs is None else specs):
        passes.append(plan_pass(kin, box, config, spec, i, q_seed, table, raster=raster))
        q_seed = passes[-1].q_start
    return tuple(passes)


def execute_scan(
    controller: Controller,
    plan: tuple[PlannedPass, ...],
    config: Scan,
    progress: Progress | None = None,
    model: CellModel | None = None,
    detect: Callable[[str, str, str], None] | None = None,
) -> ScanData:
    """Run the passes on the (real) cell with the laser in hand; every line's points are
    rebuilt with the cell's `model` (the arm the controller moves with, the laser's mounting
    and range scale, the table frame at the line's table readout; default the data
    sheet's) and go into the table frame. A pass that lost a stretch of lines (a line laser's
    plausibility) is run once more; `detect(code, message, action)` hears of it."""
    say = progress or (lambda _msg: None)
    change_tool_safely(controller, "laser")
    t0 = controller.time_s
    model = model or CellModel.nominal(controller.kinematics)
    dirs = controller.laser_directions_tcp
    points: list[np.ndarray] = []
    index: list[np.ndarray] = []
    origins: list[np.ndarray] = []
    times: list[float] = []
    which: list[int] = []
    joints: list[np.ndarray] = []
    for k, planned in enumerate(plan):
        for attempt in range(2):
            readings = _run_pass(controller, planned, config)
            gap = 0 if single_ray(dirs) else longest_gap(readings)  # see GAP_LINES
            if gap < GAP_LINES:
                break
            message = f"{planned.name}: {gap} laser lines in a row without a return"
            action = "re-scanned the pass" if attempt == 0 else "kept what it returned"
            if detect is None:
                say(f"warning: scan: {message}; {action}")
            else:
                detect("laser_gap", message, action)
        n_before = sum(len(p) for p in points)
        kin = controller.kinematics
        for reading in readings:
            valid = reading.valid
            T_base_tool = kin.fk(reading.q_measured)  # the tool sits where the flange met it
            p_tool = model.laser_points(reading.distances[valid], dirs[valid])
            p_base = p_tool @ T_base_tool[:3, :3].T + T_base_tool[:3, 3]
            T_base_table = model.T_base_table(reading.table_position_m)
            origin = (T_base_tool @ model.T_tool_laser)[None, :3, 3]
            origins.append(points_in_table_frame(origin, T_base_table)[0])
            index.append(np.full(len(p_base), len(origins) - 1))
            points.append(points_in_table_frame(p_base, T_base_table))
            times.append(reading.time_s)
            which.append(k)
            joints.append(reading.q_measured)
        n_new = sum(len(p) for p in points) - n_before
        say(f"scan {planned.name}: {len(readings)} lines, {n_new} points")
    return ScanData(
        points_table=np.concatenate(points) if points else np.zeros((0, 3)),
        line_origins_table=np.array(origins).reshape(-1, 3),
        line_index=np.concatenate(index) if index else np.zeros(0, dtype=int),
        line_times_s=np.array(times),
        line_pass=np.array(which, dtype=int),
        line_q=np.array(joints).reshape(-1, 6),
        seconds=controller.time_s - t0,
    )


#: A pass whose laser returns nothing for this many lines in a row has lost a stretch: a
#: line always sees the table or the object within the laser's range. Not a point laser's:
#: its one ray leaves its range wherever a tilted raster line runs off the object.
GAP_LINES = 5


def longest_gap(readings: list[LaserReading]) -> int:
    """The longest run of laser lines without a single return."""
    longest = run = 0
    for reading in readings:
        run = 0 if reading.valid.any() else run + 1
        longest = max(longest, run)
    return longest


#: After a pass the laser rises straight up this far [m] (or half of it where the arm does
#: not reach so high) before the arm moves on: a joint move from the end of a low, tilted
#: pass can sweep the laser through the object.
RETREAT_M = 0.15
#: ... at this speed [m/s] (the controller's default for a straight move).
RETREAT_SPEED_M_S = 0.2


def _run_pass(controller: Controller, planned: PlannedPass, config: Scan) -> list[LaserReading]:
    """One pass on the cell: the arm through its via points, the table to its position, the
    arm to its start, the sweep (a raster's lines one after the other, the arm stepping
    across between them without stopping), then the laser up and away from the object."""
    lines = [(planned.T_base(a), planned.T_base(b)) for a, b in planned.lines()]
    readings: list[LaserReading] = []
    try:
        for q in planned.q_via:
            controller.move_joints(q)
        if abs(controller.table_position() - planned.table_position_m) > 1e-6:
            controller.move_table(planned.table_position_m)
        controller.move_joints(planned.q_start)
        for k, (T_base_start, T_base_end) in enumerate(lines):
            last = k == len(lines) - 1
            if k:
                controller.move_linear(T_base_start, speed_m_s=config.speed_m_s, settle_s=0.0)
            readings += controller.scan_linear(
                T_base_end, config.speed_m_s, config.period_s, SETTLE_S if last else 0.0
            )
    except CellError as exc:
        raise UnreachablePlanError(f"{planned.name} failed on the cell: {exc}") from exc
    for T_up in risen(lines[-1][1]):
        try:
            controller.move_linear(T_up, speed_m_s=RETREAT_SPEED_M_S)
            break
        except UnreachableTargetError:
            continue
    return readings


def risen(T_base_end: np.ndarray) -> tuple[np.ndarray, ...]:
    """Where the laser rises to after a pass ending at `T_base_end` (4, 4, base frame):
    RETREAT_M straight up, else half of it where the arm does not reach so high."""
    out = []
    for rise in (RETREAT_M, RETREAT_M / 2):
        T_up = np.array(T_base_end, dtype=float)
        T_up[2, 3] += rise
        out.append(T_up)
    return tuple(out)


def crop_to_object(points_table: np.ndarray, box: ObjectBox, margin_m: float) -> np.ndarray:
    """(N,) bool: points above the table top and within the object's nominal footprint
    enlarged by `margin_m` (the region of interest a real system would crop to)."""
    p = np.asarray(points_table)
    above = p[:, 2] > TABLE_CLEARANCE_M
    near = np.linalg.norm(p[:, :2] - box.centre[:2], axis=1) <= box.radius_xy + margin_m
    below = p[:, 2] <= box.centre[2] + box.half[2] + margin_m
    return above & near & below
