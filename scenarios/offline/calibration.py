"""In-cell calibration: the laser views reference spheres on the table at several table
positions, and the cell's model (scenarios.offline.cell_model) is identified: the arm's
kinematic parameters, the compliance of its joints 2 and 3, the laser's mounting and range
scale, and the table axis' deviation from a straight travel.

What industrial cells do (absolute-accuracy calibration, sphere-artifact self-calibration),
with the sliding table in the loop: three spheres on posts stand at one end of the table; at
each of a few table positions the laser looks at each sphere from many arm configurations
(tilts, headings, turns of the laser about its axis, near and far), a few static laser lines
per view. Every laser point is rebuilt from the measured joints (the motors' angles), its
range and ray and a candidate cell model: the links sag from the motors by the gravity torque
(data-sheet inertias, the laser's nominal mass) times the compliance; the laser's optical
frame sits on its tool plate by a candidate mounting; its ranges carry a candidate scale. The
spheres' centres are unknowns in the table frame, and the table frame at each position is the
nominal straight travel moved by the table model's deviation there: seeing the same spheres at
several positions is what tells the table's pitch, yaw and bow from the arm's own errors (a
joint calibration of the arm and its 7th axis). Each point's residual is its distance from its
sphere's centre minus the sphere's certified radius. Gauss-Newton with priors from the data
sheets (`CalibrationPriors`) identifies the model jointly with the centres.

The laser's mounting on the flange is part of the model: the tool changer locks a tool where
the flange meets it, so a tool fetched with an inaccurate arm sits off its nominal mounting by
the arm's error at the rack. With the tool sitting in its slot when it is fetched, the laser in
the base frame is FK(q) FK(q_lock)^-1 T_base_slot T_tool_laser, for any candidate arm. The
flange's own parameters cancel from that product, and every tool is fetched the same way.

What the model leaves out (lost motion, pose repeatability, the other tools' TCPs, the laser's
noise) stays in the residual, which the result reports.

After the measurement the laser goes back to its slot with the kinematics that fetched it, so
that it sits where it sat; the next fetch, with the calibrated arm, mounts it closely.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from cell import Controller, FixedPrimitive, Kinematics, nominal_T_base_table
from cell.controller import RACK_APPROACH_M
from cell.errors import CellError
from cell.kinematics import payload_model
from cell.robots import Robot
from models.robot import LASER
from registration.rigid import make_T
from scenarios.errors import ScenarioError
from scenarios.offline.cell_model import CellModel, CompliantKinematics, TableModel
from scenarios.results.evaluations import CalibrationSummary

Progress = Callable[[str], None]
#: Finite-difference step of the numeric Jacobian, per prior sigma.
_STEP = 1e-3
#: How far below each view every joint starts its last move to it [rad].
APPROACH_RAD = 0.01
#: The parameter groups a calibration can identify.
GROUPS: tuple[str, ...] = ("arm", "stiffness", "laser", "table")


class CalibrationError(ScenarioError, ValueError):
    """The calibration cannot be trusted: too few views or points, or a poor fit."""


@dataclass(frozen=True)
class SphereArtifact:
    """Reference spheres on square posts standing on the table.

    `centres_table` (S, 3) the spheres' nominal centres in the table frame [m] (where the
    artifact is designed to stand; the calibration estimates the real ones), `radius_m` their
    radius [m] (a certified figure), `post_half_m` the posts' half width [m].
    """

    centres_table: np.ndarray
    radius_m: float = 0.025
    post_half_m: float = 0.006

    def __post_init__(self) -> None:
        c = np.asarray(self.centres_table, dtype=float)
        if c.ndim != 2 or c.shape[1] != 3 or len(c) < 1 or not np.all(np.isfinite(c)):
            raise CalibrationError(
                f"sphere centres must be a finite (S>=1, 3) array, got shape {c.shape}"
            )
        if not (np.isfinite(self.radius_m) and self.radius_m > 0.0):
            raise CalibrationError(f"sphere radius must be > 0 m, got {self.radius_m!r}")
        if np.any(c[:, 2] < self.radius_m + 0.01):
            raise CalibrationError(
                f"spheres must stand at least 10 mm above the table top, got centre heights "
                f"{c[:, 2].tolist()} m for a radius of {self.radius_m} m"
            )
        object.__setattr__(self, "centres_table", c)

    def fixtures(self, centres_table: np.ndarray | None = None) -> tuple[FixedPrimitive, ...]:
        """The spheres and their posts as cell fixtures, the spheres at `centres_table`
        (S, 3) [m] (default: the nominal centres)."""
        c = self.centres_table if centres_table is None else np.asarray(centres_table, float)
        out = []
        for i, centre in enumerate(c):
            out.append(
                FixedPrimitive(
                    f"calibration_sphere{i + 1}",
                    "sphere",
                    (self.radius_m,),
                    make_T(np.eye(3), centre),
                    rgba=(0.9, 0.9, 0.9, 1.0),
                )
            )
            top = centre[2] - 0.9 * self.radius_m  # the post ends inside the sphere
            out.append(
                FixedPrimitive(
                    f"calibration_post{i + 1}",
                    "box",
                    (self.post_half_m, self.post_half_m, top / 2),
                    make_T(np.eye(3), np.array([centre[0], centre[1], top / 2])),
                    rgba=(0.3, 0.3, 0.3, 1.0),
                )
            )
        return tuple(out)


#: The cell's artifact: three spheres along x at the +y end of the table, at three heights.
#: With the table at -0.25 m they stand in front of the arm, where the skull job works.
DEFAULT_ARTIFACT = SphereArtifact(
    np.array([[-0.12, 0.25, 0.09], [0.0, 0.26, 0.15], [0.12, 0.25, 0.11]]), radius_m=0.025
)


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


@dataclass(frozen=True)
class CalibrationPriors:
    """What the data sheets say before the calibration, and which groups to identify.

    - `length_sigma_m`, `offset_sigma_rad`: the arm's kinematic parameters about the nominal.
    - `stiffness_nm_rad` (joints 2, 3), `stiffness_spread`: the arm maker's joint stiffness
      and its relative uncertainty.
    - `laser_mount_sigma_m`, `laser_mount_sigma_rad`: the laser's optical frame about its
      drawing's place on the tool plate; `laser_scale_sigma`: its range linearity.
    - `table_station_sigma_m`: where the table stops at each position beyond its readout
      (its repeatability and straightness), `table_angle_sigma_rad`: its guideway's pitch,
      roll and yaw along the travel.
    - `point_sigma_m`: the laser's range noise per point (its data sheet).
    - `groups`: what is identified (GROUPS); a group left out is not modelled (a rigid arm,
      the laser as drawn, a straight table).
    """

    length_sigma_m: float = 1.0e-3
    offset_sigma_rad: float = 1.0e-3
    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = 0.3
    laser_mount_sigma_m: float = 1.0e-3
    laser_mount_sigma_rad: float = 1.0e-2
    laser_scale_sigma: float = 1.0e-3
    table_station_sigma_m: float = 5.0e-5
    table_angle_sigma_rad: float = 1.0e-4
    point_sigma_m: float = 1.0e-4
    groups: tuple[str, ...] = GROUPS

    def __post_init__(self) -> None:
        unknown = sorted(set(self.groups) - set(GROUPS))
        if unknown or "arm" not in self.groups:
            raise CalibrationError(
                f"calibration groups {list(self.groups)}: valid are {list(GROUPS)}, and the arm "
                "is always identified"
            )
        sigmas = (
            self.length_sigma_m,
            self.offset_sigma_rad,
            self.stiffness_spread,
            self.laser_mount_sigma_m,
            self.laser_mount_sigma_rad,
            self.laser_scale_sigma,
            self.table_station_sigma_m,
            self.table_angle_sigma_rad,
            self.point_sigma_m,
            *self.stiffness_nm_rad,
        )
        if not all(np.isfinite(v) and v > 0.0 for v in sigmas):
            raise CalibrationError(f"calibration priors must be finite and > 0, got {self}")


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


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The identified cell.

    Attributes:
        model: the cell's model (scenarios.offline.cell_model) for the scan, the program and
            the export; kinematics: its arm (motor angles in).
        links: the arm's rigid kinematics with the identified deviations (for a URDF).
        parameters: the names of the arm's deviations (cell.robots); deviations: (P,).
        stiffness_nm_rad: (2,) joints 2 and 3 [N m/rad] (inf: not modelled).
        laser_mount: (6,) the laser's optical frame off its drawing: translation [m] and
            rotation vector [rad], in its tool frame; laser_scale: its range scale error.
        table_coefficients: (6, 2) the table model's terms (cell_model.TableModel).
        centres_table: (S, 3) estimated sphere centres in the table frame [m].
        residual_rms_before_m: point residual RMS with the data sheet's cell (centres
            fitted) [m]; residual_rms_after_m: with the identified model: what it leaves out.
        points, views, table_positions: inlier points, arm configurations, table positions
            used; iterations of the fit; groups identified; seconds: wall time [s].
        fitted: every point as the identified model places it (for a picture of the fit).
    """

    model: CellModel
    links: Kinematics
    parameters: tuple[str, ...]
    deviations: np.ndarray
    stiffness_nm_rad: np.ndarray
    laser_mount: np.ndarray
    laser_scale: float
    table_coefficients: np.ndarray
    centres_table: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    views: int
    table_positions: int
    iterations: int
    groups: tuple[str, ...]
    seconds: float
    fitted: FittedPoints | None = None

    @property
    def kinematics(self) -> Kinematics:
        return self.model.kinematics

    def summary(self) -> CalibrationSummary:
        """The figures results.json keeps (SI units)."""
        return CalibrationSummary(
            residual_rms_before_m=self.residual_rms_before_m,
            residual_rms_after_m=self.residual_rms_after_m,
            seconds=self.seconds,
            points=self.points,
            views=self.views,
            table_positions=self.table_positions,
            iterations=self.iterations,
            groups=tuple(self.groups),
            deviations={n: float(v) for n, v in zip(self.parameters, self.deviations, strict=True)},
            stiffness_nm_rad=tuple(float(v) for v in self.stiffness_nm_rad),
            laser_mount_m=tuple(float(v) for v in self.laser_mount[:3]),
            laser_mount_rad=tuple(float(v) for v in self.laser_mount[3:]),
            laser_scale=float(self.laser_scale),
            table_coefficients=tuple(
                tuple(float(v) for v in row) for row in self.table_coefficients
            ),
        )


# -- measurement ------------------------------------------------------------------------------
def _view_pose(c: np.ndarray, tilt: float, heading: float, roll: float, d: float) -> np.ndarray:
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
            poses.append((heading, _view_pose(c, tilt, heading, roll, d)))
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


def _view_sphere(
    controller: Controller,
    sphere: int,
    q: np.ndarray,
    lines_per_view: int,
    centre_base: np.ndarray,
    artifact: SphereArtifact,
    viewed: Callable[[], None],
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """Move to the view `q` (6,) [rad] of sphere `sphere` (its nominal centre `centre_base`
    (3,) [m]), tell `viewed()`, and read `lines_per_view` laser lines standing still,
    averaged ray by ray: the mean measured joints, the table readout [m] and the points
    (M, 3) in the laser frame within the sphere's radius + 10 mm of its centre and not on
    its post; None if none is."""
    # Every joint comes to a view from the same side (from below), so that the drives' lost
    # motion is the same at every view (ISO 9283's unidirectional approach): the fit sees it
    # as a constant, not as noise.
    _move(controller, q - APPROACH_RAD, sphere, settle_s=0.0)
    _move(controller, q, sphere, settle_s=0.2)
    viewed()
    readings = [controller.read_laser() for _ in range(lines_per_view)]
    ranges = np.array([r.distances for r in readings])
    index = np.flatnonzero(np.all(np.isfinite(ranges), axis=0))
    q_view = np.mean([r.q_measured for r in readings], axis=0)
    p_laser = controller.laser_directions_tcp[index] * ranges[:, index].mean(axis=0)[:, None]
    T = controller.kinematics.fk(q_view) @ controller.T_flange_tcp()
    rel = p_laser @ T[:3, :3].T + T[:3, 3] - centre_base
    margin = artifact.radius_m + 0.01
    keep = (np.linalg.norm(rel, axis=1) < margin) & (rel[:, 2] > -0.6 * artifact.radius_m)
    if not np.any(keep):
        return None
    return q_view, readings[0].table_position_m, p_laser[keep]


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
) -> SphereMeasurements:
    """Fetch the laser; at each of the plan's table positions, view every sphere; points
    within the radius + 10 mm of a sphere's nominal centre (and not on its post) are kept.
    The laser ends back in its slot, put there with the kinematics that fetched it.
    `on_view()` is called with the arm at each view (e.g. to record the cell); only views
    `clear` of the object are taken."""
    say = progress or (lambda _msg: None)
    viewed = on_view or (lambda: None)
    if controller.tool_in_hand == LASER.name:
        raise CalibrationError(
            "the laser is already in hand: the calibration fetches it from its slot itself "
            "(its mounting on the flange follows from the fetch)"
        )
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
            if seen is None:
                continue
            q_view, table_position_m, keep_points = seen
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


# -- identification ---------------------------------------------------------------------------
#: The parts of a parameter vector: deviations, compliance, mounting, scale, table terms.
_Parts = tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]


@dataclass(frozen=True, eq=False)
class _Layout:
    """The calibration's parameter vector: the arm's deviations (P), the compliance of
    joints 2 and 3 (2) [rad/(N m)], the laser's mounting (6: translation [m], rotation
    vector [rad]) and range scale (1), the table model's coefficients (12, row-major (6, 2):
    its translation terms are left to the stations, its rotation terms are the guideway's
    pitch, roll and yaw), and where the table stood at each station beyond its readout
    (3 per station [m], the first station the gauge: the spheres' centres take it up); each
    entry's prior mean and sigma, and which are free."""

    P: int
    stations: int
    mean: np.ndarray
    sigma: np.ndarray
    free: np.ndarray

    @classmethod
    def of(cls, robot: Robot, priors: CalibrationPriors, stations: int = 1) -> _Layout:
        P = len(robot.parameters)
        k = np.asarray(priors.stiffness_nm_rad, dtype=float)
        compliance = 1.0 / k
        n = 3 * stations
        mean = np.concatenate([np.zeros(P), compliance, np.zeros(7), np.zeros(12), np.zeros(n)])
        table_sigma = np.repeat(
            [priors.table_station_sigma_m] * 3 + [priors.table_angle_sigma_rad] * 3, 2
        )
        sigma = np.concatenate(
            [
                robot.sigmas(priors.length_sigma_m, priors.offset_sigma_rad),
                compliance * priors.stiffness_spread,
                [priors.laser_mount_sigma_m] * 3 + [priors.laser_mount_sigma_rad] * 3,
                [priors.laser_scale_sigma],
                table_sigma,
                np.full(n, priors.table_station_sigma_m),
            ]
        )
        groups = set(priors.groups)
        table_free = np.repeat([False] * 3 + ["table" in groups] * 3, 2)
        free = np.concatenate(
            [
                np.asarray(robot.identified, dtype=bool),
                np.full(2, "stiffness" in groups),
                np.full(7, "laser" in groups),
                table_free,
                np.r_[np.zeros(3, dtype=bool), np.ones(n - 3, dtype=bool)],
            ]
        )
        if "stiffness" not in groups:
            mean[P : P + 2] = 0.0  # not modelled: a rigid arm
        return cls(P, stations, mean, sigma, free)

    @property
    def table_start(self) -> int:
        """Index of the first entry that moves the table frames, not the points."""
        return self.P + 9

    def unpack(self, theta: np.ndarray) -> _Parts:
        P = self.P
        return (
            theta[:P],
            theta[P : P + 2],
            theta[P + 2 : P + 8],
            float(theta[P + 8]),
            theta[P + 9 : P + 21].reshape(6, 2),
        )

    def station_offsets(self, theta: np.ndarray) -> np.ndarray:
        """(stations, 3) where the table stood at each station beyond its readout [m]."""
        return theta[self.P + 21 :].reshape(self.stations, 3)


def _mount(mount: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(mount[3:]).as_matrix()
    T[:3, 3] = mount[:3]
    return T


class _Model:
    """Evaluates the measured points and the spheres' centres in the base frame for a
    candidate parameter vector."""

    def __init__(self, m: SphereMeasurements, robot: Robot, layout: _Layout) -> None:
        self.m, self.robot, self.layout = m, robot, layout
        self._arms: dict[bytes, Kinematics] = {}
        nominal = robot.kinematics()
        loaded = payload_model(nominal, LASER.name)
        bare = payload_model(nominal, None)
        data_l, data_b = loaded.createData(), bare.createData()
        self.g_lines = np.array(
            [pin.computeGeneralizedGravity(loaded, data_l, q) for q in m.q_lines]
        )
        self.g_lock = np.asarray(pin.computeGeneralizedGravity(bare, data_b, m.q_lock))

    def _kinematics(self, dev: np.ndarray) -> Kinematics:
        """The arm with deviations `dev`, built once per distinct vector (a Jacobian's
        columns other than the arm's own reuse the current arm)."""
        key = np.asarray(dev, dtype=float).tobytes()
        if key not in self._arms:
            if len(self._arms) > 32:
                self._arms.clear()
            self._arms[key] = self.robot.kinematics(dev)
        return self._arms[key]

    def points(self, theta: np.ndarray) -> np.ndarray:
        """(N, 3) the measured points in the base frame [m]."""
        m = self.m
        dev, compliance, mount, scale, _ = self.layout.unpack(theta)
        kin = self._kinematics(dev)
        c6 = np.zeros(6)
        c6[1:3] = compliance
        q_lock = m.q_lock - c6 * self.g_lock
        T_flange_laser = np.linalg.solve(kin.fk(q_lock), m.T_base_slot) @ m.T_tool_laser
        T_flange_laser = T_flange_laser @ _mount(mount)
        q_links = m.q_lines - c6 * self.g_lines
        T = np.array([kin.fk(q) @ T_flange_laser for q in q_links])[m.line]
        p = m.p_laser / (1.0 + scale)
        return np.einsum("nij,nj->ni", T[:, :3, :3], p) + T[:, :3, 3]

    def tables(self, theta: np.ndarray) -> np.ndarray:
        """(L, 4, 4) the table frame at each line's table position (its station's)."""
        table = TableModel(self.layout.unpack(theta)[4])
        offsets = self.layout.station_offsets(theta)
        out = table.T_base_tables(self.m.table_lines)
        out[:, :3, 3] += np.einsum("lij,lj->li", out[:, :3, :3], offsets[self.m.station_lines])
        return out


def _residuals(
    p: np.ndarray, T_tables: np.ndarray, centres: np.ndarray, m: SphereMeasurements
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residuals (N,), unit directions from the centres (N, 3) and each point's table
    rotation (N, 3, 3)."""
    T = T_tables[m.line]
    c = np.einsum("nij,nj->ni", T[:, :3, :3], centres[m.sphere]) + T[:, :3, 3]
    d = p - c
    norm = np.linalg.norm(d, axis=1)
    return norm - m.radius_m, d / norm[:, None], T[:, :3, :3]


def _fit(
    model: _Model,
    use: np.ndarray,
    theta: np.ndarray,
    centres: np.ndarray,
    free: np.ndarray,
    point_sigma_m: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Gauss-Newton on the points `use` (N,) bool: the spheres' centres (table frame) and the
    `free` (mask) entries of the parameter vector, each held by its prior."""
    m, layout = model.m, model.layout
    S = len(centres)
    theta, c = theta.copy(), centres.copy()
    idx = np.flatnonzero(free)
    sphere = m.sphere[use]
    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 (the count is returned)
        p = model.points(theta)
        tables = model.tables(theta)
        res, n, R = _residuals(p, tables, c, m)
        res, n, R = res[use], n[use], R[use]
        J_c = np.zeros((len(res), 3 * S))
        nR = -np.einsum("ni,nij->nj", n, R)
        for k in range(S):
            J_c[sphere == k, 3 * k : 3 * k + 3] = nR[sphere == k]
        J_t = np.empty((len(res), len(idx)))
        for col, j in enumerate(idx):
            h = _STEP * layout.sigma[j]
            step = theta.copy()
            step[j] += h
            p_j = model.points(step) if j < layout.table_start else p
            t_j = model.tables(step) if j >= layout.table_start else tables
            r_j = _residuals(p_j, t_j, c, m)[0][use]
            J_t[:, col] = (r_j - res) / h * layout.sigma[j]  # per prior sigma
        z = (theta[idx] - layout.mean[idx]) / layout.sigma[idx]
        J = np.vstack(
            [
                np.hstack([J_t, J_c]) / point_sigma_m,
                np.hstack([np.eye(len(idx)), np.zeros((len(idx), 3 * S))]),
            ]
        )
        rvec = np.concatenate([res / point_sigma_m, z])
        delta = np.linalg.lstsq(J, -rvec, rcond=None)[0]
        theta[idx] = theta[idx] + delta[: len(idx)] * layout.sigma[idx]
        step_c = delta[len(idx) :].reshape(S, 3)
        c = c + step_c
        if np.max(np.abs(delta[: len(idx)]), initial=0.0) < 1e-6 and np.max(np.abs(step_c)) < 1e-9:
            break
    return theta, c, done


@dataclass(frozen=True, eq=False)
class Identification:
    """The fit: the parameter vector (see `_Layout`), sphere centres (S, 3) in the table
    frame [m], point residual RMS with the data sheet's cell and with the identified one [m]
    (centres fitted for each), inlier points used, Gauss-Newton iterations of both fits."""

    theta: np.ndarray
    centres_table: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    iterations: int
    fitted: FittedPoints | None = None


@dataclass(frozen=True, eq=False)
class FittedPoints:
    """Every measured point as the identified model places it, for a picture of the fit:
    its position (N, 3) in the table frame [m], its residual (N,) from its sphere with the
    identified model and with the data sheet's [m], whether the fit used it (N,), its
    sphere (N,) and its view (N,)."""

    points_table: np.ndarray
    residuals_m: np.ndarray
    residuals_before_m: np.ndarray
    used: np.ndarray
    sphere: np.ndarray
    view: np.ndarray


def identify(
    m: SphereMeasurements,
    robot: Robot,
    priors: CalibrationPriors | None = None,
    *,
    max_residual_rms_m: float = 1e-4,
    min_points_per_sphere: int = 200,
    iterations: int = 10,
) -> Identification:
    """Identify the cell's model (see the module's docstring) from the measurements, each
    group held by its data-sheet prior (`priors`). Points whose residual is beyond 4 robust
    sigmas (at least 0.3 mm) of a first fit are dropped. Raises CalibrationError for too few
    points on a sphere or a poor fit."""
    priors = priors or CalibrationPriors()
    S = len(m.centres_table)
    counts = np.bincount(m.sphere, minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"points per sphere {counts.tolist()}: each sphere needs at least "
            f"{min_points_per_sphere} laser points"
        )
    layout = _Layout.of(robot, priors, m.stations)
    model = _Model(m, robot, layout)
    sigma_p = priors.point_sigma_m
    use = np.ones(m.points, dtype=bool)
    theta, c, its_first = _fit(
        model, use, layout.mean.copy(), m.centres_table, layout.free, sigma_p, iterations
    )
    res = _residuals(model.points(theta), model.tables(theta), c, m)[0]
    sigma = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    use = np.abs(res) <= max(4.0 * sigma, 3e-4)
    counts = np.bincount(m.sphere[use], minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"inlier points per sphere {counts.tolist()} after the first fit: each sphere "
            f"needs at least {min_points_per_sphere}"
        )
    theta, c, its = _fit(model, use, theta, c, layout.free, sigma_p, iterations)
    p_base, tables = model.points(theta), model.tables(theta)
    all_after = _residuals(p_base, tables, c, m)[0]
    after = all_after[use]
    nominal = np.zeros_like(theta)
    _, c0, _ = _fit(model, use, nominal, c, np.zeros_like(layout.free), sigma_p, iterations)
    all_before = _residuals(model.points(nominal), model.tables(nominal), c0, m)[0]
    before = all_before[use]
    T = tables[m.line]
    in_table = np.einsum("nji,nj->ni", T[:, :3, :3], p_base - T[:, :3, 3])
    fitted = FittedPoints(in_table, all_after, all_before, use, m.sphere, m.line)
    rms_before = float(np.sqrt(np.mean(before**2)))
    rms_after = float(np.sqrt(np.mean(after**2)))
    if not rms_after <= max_residual_rms_m:
        raise CalibrationError(
            f"the calibration's residual RMS is {rms_after * 1e3:.3f} mm after the fit "
            f"({rms_before * 1e3:.3f} mm before), above the limit of "
            f"{max_residual_rms_m * 1e3:.3f} mm: the spheres or the views are not as planned"
        )
    return Identification(theta, c, rms_before, rms_after, int(use.sum()), its_first + its, fitted)


def cell_model(robot: Robot, fit: Identification, priors: CalibrationPriors) -> CellModel:
    """The cell's model from a fit: the arm (compliant if its stiffness was identified), the
    laser's mounting and scale, the table."""
    layout = _Layout.of(robot, priors, (len(fit.theta) - len(robot.parameters) - 21) // 3)
    dev, compliance, mount, scale, table = layout.unpack(fit.theta)
    links = robot.kinematics(dev)
    kinematics: Kinematics = links
    if "stiffness" in priors.groups:
        kinematics = CompliantKinematics(links, compliance)
    return CellModel(kinematics, LASER.T_tool_tcp @ _mount(mount), scale, TableModel(table))


def calibrate(
    controller: Controller,
    artifact: SphereArtifact = DEFAULT_ARTIFACT,
    plan: CalibrationPlan | None = None,
    max_residual_rms_m: float = 1e-4,
    progress: Progress | None = None,
    on_view: Callable[[], None] | None = None,
    priors: CalibrationPriors | None = None,
    clear: Clear | None = None,
) -> CalibrationResult:
    """Measure the artifact (the views `clear` of the object) and identify the cell (see
    the module's docstring). The controller is left as it was: the caller decides to use
    the result."""
    t0 = time.perf_counter()
    plan = plan or CalibrationPlan()
    priors = priors or CalibrationPriors()
    m = measure_spheres(controller, artifact, plan, progress, on_view, clear)
    robot = controller.robot
    fit = identify(m, robot, priors, max_residual_rms_m=max_residual_rms_m)
    layout = _Layout.of(robot, priors, m.stations)
    dev, compliance, mount, scale, table = layout.unpack(fit.theta)
    stiffness = np.where(compliance > 0.0, 1.0 / np.where(compliance > 0, compliance, 1.0), np.inf)
    return CalibrationResult(
        cell_model(robot, fit, priors),
        robot.kinematics(dev),
        robot.parameters,
        dev,
        stiffness,
        mount,
        scale,
        table,
        fit.centres_table,
        fit.residual_rms_before_m,
        fit.residual_rms_after_m,
        fit.points,
        m.views,
        len(plan.table_positions_m),
        fit.iterations,
        tuple(priors.groups),
        time.perf_counter() - t0,
        fit.fitted,
    )
