"""The calibration's measurement: how the spheres are viewed (`CalibrationPlan`), the views
planned clear of the object, and the laser lines read at each (`SphereMeasurements`, no
truth in them).

The laser is fetched from its slot (its mounting on the flange follows from the fetch); at
each of the plan's table positions it looks at each sphere from many arm configurations
(tilts, headings, turns of the laser about its axis, near and far), a few static laser lines
per view (a point laser: at a few stops across the sphere), every joint coming to a view
from below; it ends back in its slot, put there with the kinematics that fetched it
(scenarios.offline.calibration).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller, Kinematics, nominal_T_base_table
from cell.cell_errors import CellError, UnreachableTargetError
from cell.controller import RACK_APPROACH_M
from models.robot import LASER
from registration.rigid import make_T
from scenarios.offline.calibration_artifact import CalibrationError, SphereArtifact
from scenarios.offline.laser_sheet import single_ray

Progress = Callable[[str], None]
#: How far below each view every joint starts its last move to it [rad].
APPROACH_RAD = 0.01


@dataclass(frozen=True)
class CalibrationPlan:
    """How the spheres are viewed: the table positions [m] (the spheres seen at each),
    views per sphere (over all positions), static laser lines per view (averaged ray by
    ray), the laser's distance from the sphere's centre (near, far) [m], the largest tilt of
    the view from the vertical [rad], the seed of the views' spread.

    The lines of a view average the laser's noise, not the arm's: each view lands within
    the arm's pose repeatability, one error shared by all its points. The views average
    that: with 24 views the scan's passes were 0.2-0.4 mm apart after the calibration, with
    48 within 0.1 mm."""

    table_positions_m: tuple[float, ...] = (-0.45, -0.25, -0.05)
    views_per_sphere: int = 48
    lines_per_view: int = 10
    standoff_m: tuple[float, float] = (0.18, 0.32)
    max_tilt_rad: float = float(np.deg2rad(55.0))
    seed: int = 0


@dataclass(frozen=True, eq=False)
class SphereMeasurements:
    """Laser lines on the spheres, as measured (no truth).

    Attributes:
        q_lines: (L, 6) measured joints of each line [rad] (a view's lines averaged).
        table_lines: (L,) the table's readout [m] at each line; station_lines: (L,) the
            table station (one stop of the table) of each line.
        line: (N,) the line of each point; sphere: (N,) the sphere of each point.
        p_laser: (N, 3) each point in the laser's optical frame (mean range times ray) [m].
        q_lock: (6,) measured joints when the laser was locked in its slot [rad].
        T_base_slot: (4, 4) the laser's rack slot; T_tool_laser: (4, 4) its drawing's TCP.
        centres_table: (S, 3) the spheres' nominal centres in the table frame [m].
        radius_m: the spheres' radius [m]; views: arm configurations measured.
    """

    q_lines: np.ndarray
    table_lines: np.ndarray
    station_lines: np.ndarray
    line: np.ndarray
    sphere: np.ndarray
    p_laser: np.ndarray
    q_lock: np.ndarray
    T_base_slot: np.ndarray
    T_tool_laser: np.ndarray
    centres_table: np.ndarray
    radius_m: float
    views: int

    @property
    def points(self) -> int:
        return len(self.p_laser)

    @property
    def stations(self) -> int:
        return int(self.station_lines.max()) + 1 if len(self.station_lines) else 1


def view_pose(c: np.ndarray, tilt: float, heading: float, roll: float, d: float) -> np.ndarray:
    """(4, 4) laser TCP pose looking at `c` (3,) from `d` [m] away, its view tilted by `tilt`
    from straight down towards `heading` (about z), turned by `roll` about the view."""
    v = np.array([np.sin(tilt) * np.cos(heading), np.sin(tilt) * np.sin(heading), -np.cos(tilt)])
    ref = np.array([0.0, 0.0, 1.0]) if abs(v[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(ref, v)
    x /= np.linalg.norm(x)
    x = np.cos(roll) * x + np.sin(roll) * np.cross(v, x)
    return make_T(np.column_stack([x, np.cross(v, x), v]), c - d * v)


#: Says whether the arm with the laser at joints q (6,) stands clear of what is on the
#: table, with the table at a position [m] (the virtual cell's view of it).
Clear = Callable[[np.ndarray, float], bool]


#: The largest joint's step [rad] between the samples at which a calibration move is checked
#: clear of the object (about 10 mm of the laser's travel at a metre's reach).
PATH_STEP_RAD = 0.01


def path_clear(clear: Clear, q0: np.ndarray, q1: np.ndarray, table_position_m: float) -> bool:
    """Whether the joint move q0 -> q1 (a line in joint space, as the controller moves),
    sampled every PATH_STEP_RAD of its largest joint, stays `clear` of the object. A move
    that starts where the arm is not clear (the arm stands within the margin already) may
    leave that region, but not enter it again once clear."""
    q0 = np.asarray(q0, dtype=float)
    dq = np.asarray(q1, dtype=float) - q0
    n = max(1, int(np.ceil(float(np.max(np.abs(dq))) / PATH_STEP_RAD)))
    leaving = not clear(q0, table_position_m)
    for k in range(1, n + 1):
        ok = clear(q0 + (k / n) * dq, table_position_m)
        if not ok and not leaving:
            return False
        leaving = leaving and not ok
    return not leaving


@dataclass(frozen=True)
class View:
    """A planned view of a sphere: the sphere's index, the joints (6,) [rad] of the view,
    and whether the arm goes to it through home (the direct move is not clear)."""

    sphere: int
    q: np.ndarray
    through_home: bool = False


def plan_views(
    kin: Kinematics,
    centres_base: np.ndarray,
    plan: CalibrationPlan,
    q_home: np.ndarray,
    clear: Clear | None = None,
    q_start: np.ndarray | None = None,
) -> list[View]:
    """Every reachable view (its approach from below included) that stands `clear` of the
    object on the table (at the plan's table position), spread over tilt, heading, roll and
    distance (golden-ratio sequences), ordered by heading around each sphere; the IK starts
    from home `q_home`, then from the view before. With `q_start` (the joints the arm starts
    from), the move to a view from the view before (from `q_start` for the first) must stay
    clear too: where it does not, the arm goes through home if both legs are clear, and
    the view is left out if not; so are the last views if the move home from them is not
    clear."""
    rng = np.random.default_rng(plan.seed)
    q_from = None if q_start is None else np.asarray(q_start, dtype=float)
    golden = (np.sqrt(5.0) - 1.0) / 2.0
    near, far = plan.standoff_m
    views = []
    home = np.asarray(q_home, dtype=float)
    q = home
    for s, c in enumerate(centres_base):
        start = rng.uniform(0.0, 1.0, 3)
        n = plan.views_per_sphere
        poses = []
        for k in range(n):
            tilt = plan.max_tilt_rad * np.sqrt((k + 0.5) / n)
            heading = 2 * np.pi * ((start[0] + k * golden) % 1.0)
            roll = np.pi * (2 * ((start[1] + k * golden**2) % 1.0) - 1)
            d = near + (far - near) * ((start[2] + k * golden**3) % 1.0)
            poses.append((heading, view_pose(c, tilt, heading, roll, d)))
        for _heading, T in sorted(poses, key=lambda item: item[0]):
            r = kin.ik(T, q, LASER.T_tool_tcp, extra_seeds=8)
            # The view is approached from below (APPROACH_RAD): that start must be in range.
            if not (r.success and np.all(r.q - APPROACH_RAD >= kin.lower)):
                continue
            position = plan.table_positions_m[0]
            approach = r.q - APPROACH_RAD
            through_home = False
            if clear is not None:
                if not (clear(r.q, position) and clear(approach, position)):
                    continue
                if q_from is not None and not path_clear(clear, q_from, approach, position):
                    # (a move into home is checked from home: home may stand within the
                    # margin, which the arm may enter there only)
                    through_home = path_clear(clear, home, q_from, position) and path_clear(
                        clear, home, approach, position
                    )
                    if not through_home:
                        continue
            views.append(View(s, r.q, through_home))
            q = r.q
            q_from = r.q
    # The arm goes home after the last view: that move must be clear too.
    while clear is not None and q_start is not None and views:
        if path_clear(clear, home, views[-1].q, plan.table_positions_m[0]):
            break
        views.pop()
    return views


def _fetch_laser(controller: Controller) -> np.ndarray:
    """Fetch the laser from its slot through the home pose; the joints (6,) [rad] at the lock
    (averaged encoder readings)."""
    controller.move_joints(controller.q_home)
    controller.return_tool()
    T_slot = controller.T_base_slot(LASER.name)
    T_above = T_slot.copy()
    T_above[2, 3] += RACK_APPROACH_M
    controller.move_joints(controller.kinematics.solve(T_above, controller.read_joints()))
    controller.move_linear(T_slot, speed_m_s=0.1)
    q_lock = np.mean([controller.read_joints() for _ in range(10)], axis=0)
    controller.lock()
    controller.move_linear(T_above @ controller.T_flange_tcp(), speed_m_s=0.1)
    return q_lock


def _move(controller: Controller, q: np.ndarray, sphere: int, settle_s: float = 0.0) -> None:
    """A joint move on the way to a view of sphere `sphere`; CalibrationError if it fails."""
    try:
        controller.move_joints(q, settle_s=settle_s)
    except CellError as exc:
        raise CalibrationError(f"a calibration view of sphere {sphere + 1} failed: {exc}") from exc


#: A point laser's stops across a sphere at each view: this many, evenly within this many
#: radii either side of the view along the laser's x axis, each reached by a joint move (a
#: straight line between two would cross the wrist's singularity where the laser looks
#: straight down: a controller refuses it). It reads standing still at each, averaged, as
#: the line laser does at its views: a single reading, or readings taken while the arm
#: moves, calibrate the arm worse.
STOPS = 7
STOP_RADII = 0.9

#: What a view reads: (measured joints (6,) [rad], table readout [m], points (M, 3) in the
#: laser frame [m]), one per view of a line laser, one per stop of a point laser.
Line = tuple[np.ndarray, float, np.ndarray]


def _view_sphere(
    controller: Controller,
    sphere: int,
    q: np.ndarray,
    lines_per_view: int,
    centre_base: np.ndarray,
    artifact: SphereArtifact,
    viewed: Callable[[], None],
) -> list[Line]:
    """Move to the view `q` (6,) [rad] of sphere `sphere` (its nominal centre `centre_base`
    (3,) [m]), tell `viewed()`, and read it: a line laser reads `lines_per_view` lines
    standing still, averaged ray by ray (one line: the mean measured joints, the table
    readout and the points); a point laser stops at places across the sphere and reads as
    many at each (`_stops`: a line per stop). Only points within the sphere's radius + 10 mm
    of its centre and not on its post are kept; a line left without one is dropped."""
    # Every joint comes to a view from the same side (from below), so that the drives' lost
    # motion is the same at every view (ISO 9283's unidirectional approach): the fit sees it
    # as a constant, not as noise.
    _move(controller, q - APPROACH_RAD, sphere, settle_s=0.0)
    _move(controller, q, sphere, settle_s=0.2)
    viewed()
    dirs = controller.laser_directions_tcp
    if single_ray(dirs):
        lines = _stops(controller, sphere, artifact.radius_m, lines_per_view)
    else:
        readings = [controller.read_laser() for _ in range(lines_per_view)]
        ranges = np.array([r.distances for r in readings])
        index = np.flatnonzero(np.all(np.isfinite(ranges), axis=0))
        q_view = np.mean([r.q_measured for r in readings], axis=0)
        p_laser = dirs[index] * ranges[:, index].mean(axis=0)[:, None]
        lines = [(q_view, readings[0].table_position_m, p_laser)]
    margin = artifact.radius_m + 0.01
    out = []
    for q_line, table_m, p_laser in lines:
        T = controller.kinematics.fk(q_line) @ controller.T_flange_tcp()
        rel = p_laser @ T[:3, :3].T + T[:3, 3] - centre_base
        keep = (np.linalg.norm(rel, axis=1) < margin) & (rel[:, 2] > -0.6 * artifact.radius_m)
        if np.any(keep):
            out.append((q_line, table_m, p_laser[keep]))
    return out


def _stops(controller: Controller, sphere: int, radius_m: float, readings: int) -> list[Line]:
    """A point laser's stops across the sphere it looks at: STOPS places along the laser's x
    axis within STOP_RADII radii of the view, `readings` readings standing still at each,
    averaged (a line per stop with a return; a stop the arm does not reach is left out,
    before it moves)."""
    T_view = controller.kinematics.fk(controller.read_joints()) @ controller.T_flange_tcp()
    out = []
    for u in np.linspace(-STOP_RADII, STOP_RADII, STOPS):
        T = T_view.copy()
        T[:3, 3] += u * radius_m * T_view[:3, 0]
        if not controller.reachable(T):
            continue
        try:
            q_stop = controller.solve_ik(T)
        except UnreachableTargetError:
            continue
        _move(controller, q_stop, sphere, settle_s=0.2)
        got = [controller.read_laser() for _ in range(readings)]
        d = np.array([r.distances[0] for r in got])
        if np.all(np.isfinite(d)):
            q = np.mean([r.q_measured for r in got], axis=0)
            out.append((q, got[0].table_position_m, controller.laser_directions_tcp * d.mean()))
    return out


def _station(
    controller: Controller,
    kin: Kinematics,
    artifact: SphereArtifact,
    plan: CalibrationPlan,
    clear: Clear | None,
) -> tuple[np.ndarray, list[View]]:
    """Move the table to the one position of `plan` (with the arm at home first, where home
    is clear of the object at both table positions); the spheres' nominal centres (S, 3) in
    the base frame there and the views planned from where the arm stands."""
    (position,) = plan.table_positions_m
    if clear is not None and all(
        clear(controller.q_home, at) for at in (controller.table_position(), position)
    ):
        controller.move_joints(controller.q_home)
    controller.move_table(position)
    T_base_table = nominal_T_base_table(controller.table_position())
    centres = artifact.centres_table @ T_base_table[:3, :3].T + T_base_table[:3, 3]
    return centres, plan_views(
        kin, centres, plan, controller.q_home, clear, controller.read_joints()
    )


def measure_spheres(
    controller: Controller,
    artifact: SphereArtifact,
    plan: CalibrationPlan,
    progress: Progress | None = None,
    on_view: Callable[[], None] | None = None,
    clear: Clear | None = None,
    put_back: bool = True,
) -> SphereMeasurements:
    """Fetch the laser; at each of the plan's table positions, view every sphere; points
    within the radius + 10 mm of a sphere's nominal centre (and not on its post) are kept.
    The laser ends back in its slot, put there with the kinematics that fetched it (not
    `put_back`: it stays in hand, the arm at home); a laser found in hand is put back first
    (its mounting on the flange follows from the fetch). `on_view()` is called with the arm
    at each view (e.g. to record the cell); only views `clear` of the object are taken."""
    say = progress or (lambda _msg: None)
    viewed = on_view or (lambda: None)
    if not plan.table_positions_m:
        raise CalibrationError("the calibration needs at least one table position")
    q_lock = _fetch_laser(controller)
    kin = controller.kinematics
    per_position = max(2, round(plan.views_per_sphere / len(plan.table_positions_m)))
    q_lines, table_lines, station_lines, lines, spheres, points = [], [], [], [], [], []
    margin = artifact.radius_m + 0.01
    n_views = 0
    for k, position in enumerate(plan.table_positions_m):
        sub = CalibrationPlan(
            (position,), per_position, plan.lines_per_view, plan.standoff_m, plan.max_tilt_rad,
            plan.seed + 1000 * k,
        )  # fmt: skip
        centres, views = _station(controller, kin, artifact, sub, clear)
        n_views += len(views)
        for view in views:
            s = view.sphere
            if view.through_home:
                _move(controller, controller.q_home, s)
            seen = _view_sphere(
                controller, s, view.q, plan.lines_per_view, centres[s], artifact, viewed
            )
            for q_view, table_position_m, keep_points in seen:
                q_lines.append(q_view)
                table_lines.append(table_position_m)
                station_lines.append(k)
                lines.append(np.full(len(keep_points), len(q_lines) - 1))
                spheres.append(np.full(len(keep_points), s))
                points.append(keep_points)
    say(
        f"calibration: {n_views} views of {len(artifact.centres_table)} spheres at "
        f"{len(plan.table_positions_m)} table positions, {len(q_lines)} lines"
    )
    controller.move_joints(controller.q_home)
    if put_back:
        controller.return_tool()
    if not points:
        raise CalibrationError(
            f"no laser point within {margin * 1e3:.0f} mm of any sphere's nominal centre in "
            f"{n_views} views: is the artifact on the table (table at "
            f"{list(plan.table_positions_m)} m)?"
        )
    return SphereMeasurements(
        np.array(q_lines),
        np.array(table_lines),
        np.array(station_lines, dtype=int),
        np.concatenate(lines),
        np.concatenate(spheres),
        np.concatenate(points),
        q_lock,
        controller.T_base_slot(LASER.name),
        LASER.T_tool_tcp,
        artifact.centres_table.copy(),
        artifact.radius_m,
        n_views,
    )
