"""In-cell kinematic calibration of the arm: the laser views reference spheres, the arm's
kinematic parameters are identified.

What industrial cells do (absolute-accuracy calibration, sphere-artifact self-calibration):
three spheres on posts are fixed at one end of the sliding table; the table stays still while
the laser looks at each sphere from many arm configurations (tilts, headings, turns of the
laser about its axis, near and far), a few static laser lines per view. Every laser point is
reconstructed from the measured joints, its range and ray, and a candidate arm geometry; its
residual is its distance to its sphere's centre minus the sphere's radius. Gauss-Newton with
a weak prior on the deviations identifies the arm's kinematic parameters (cell.robots: the
built-in arm's six link lengths and six joint zero offsets; another arm's zero offset and axis
position of each joint) jointly with the spheres' centres, which need not be known.

The laser's mounting on the flange is part of the model: the tool changer locks a tool where
the flange meets it, so a tool fetched with an inaccurate arm sits off its nominal mounting by
the arm's error at the rack. With the tool sitting in its slot when it is fetched, the laser in
the base frame is FK(q) FK(q_lock)^-1 T_base_slot T_tool_laser, for any candidate geometry.
The flange's length d6 and joint 6's offset cancel from that product: no laser measurement
sees them, and no job needs them, since every tool is fetched the same way. A turn of the
whole arm about joint 1 and a shift along it (joint 1's offset, d1) are seen only through the
laser's mounting, weakly; a job whose scan and touches use the same kinematics barely feels
them. The prior holds what the data do not determine at the nominal values.

After the measurement the laser goes back to its slot with the kinematics that fetched it, so
that it sits where it sat; the next fetch, with the calibrated kinematics, mounts it closely.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller, FixedPrimitive, Kinematics, nominal_T_base_table
from cell.controller import RACK_APPROACH_M
from cell.errors import CellError
from cell.robots import Robot
from models.robot import LASER
from registration.rigid import make_T
from scenarios.errors import ScenarioError

Progress = Callable[[str], None]
#: Finite-difference step of the numeric Jacobian [m or rad].
_STEP = 1e-6


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
    """How the spheres are viewed: the table position [m], views per sphere, static laser
    lines per view (averaged ray by ray), the laser's distance from the sphere's centre
    (near, far) [m], the largest tilt of the view from the vertical [rad], the seed of the
    views' spread."""

    table_position_m: float = -0.25
    views_per_sphere: int = 20
    lines_per_view: int = 10
    standoff_m: tuple[float, float] = (0.18, 0.32)
    max_tilt_rad: float = float(np.deg2rad(55.0))
    seed: int = 0


@dataclass(frozen=True, eq=False)
class SphereMeasurements:
    """Laser lines on the spheres, as measured (no truth).

    Attributes:
        q_lines: (L, 6) measured joints of each line [rad] (a view's lines averaged).
        line: (N,) the line of each point; sphere: (N,) the sphere of each point.
        p_laser: (N, 3) each point in the laser TCP frame (mean range times ray) [m].
        q_lock: (6,) measured joints when the laser was locked in its slot [rad].
        T_base_slot: (4, 4) the laser's rack slot; T_tool_laser: (4, 4) the laser's TCP.
        centres_base: (S, 3) the spheres' nominal centres in the base frame [m].
        radius_m: the spheres' radius [m]; views: arm configurations measured.
    """

    q_lines: np.ndarray
    line: np.ndarray
    sphere: np.ndarray
    p_laser: np.ndarray
    q_lock: np.ndarray
    T_base_slot: np.ndarray
    T_tool_laser: np.ndarray
    centres_base: np.ndarray
    radius_m: float
    views: int

    @property
    def points(self) -> int:
        return len(self.p_laser)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The identified arm.

    Attributes:
        kinematics: Pinocchio on the calibrated arm.
        parameters: the names of the arm's deviations (cell.robots).
        deviations: (P,) identified deviations from the nominal [m, rad].
        centres_base: (S, 3) estimated sphere centres in the base frame [m].
        residual_rms_before_m: point residual RMS with the nominal arm (centres fitted) [m].
        residual_rms_after_m: the same with the calibrated arm [m].
        points, views: inlier points and arm configurations used; iterations of the fit.
        seconds: wall time of measurement and identification [s].
    """

    kinematics: Kinematics
    parameters: tuple[str, ...]
    deviations: np.ndarray
    centres_base: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    views: int
    iterations: int
    seconds: float

    def summary(self) -> dict[str, object]:
        """The figures for results.json (SI units)."""
        return {
            "residual_rms_before_m": self.residual_rms_before_m,
            "residual_rms_after_m": self.residual_rms_after_m,
            "seconds": self.seconds,
            "points": self.points,
            "views": self.views,
            "iterations": self.iterations,
            "deviations": {
                n: float(v) for n, v in zip(self.parameters, self.deviations, strict=True)
            },
        }


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


def plan_views(
    kin: Kinematics, centres_base: np.ndarray, plan: CalibrationPlan, q_seed: np.ndarray
) -> list[tuple[int, np.ndarray]]:
    """(sphere, joints (6,)) of every reachable view, spread over tilt, heading, roll and
    distance (golden-ratio sequences), ordered by heading around each sphere."""
    rng = np.random.default_rng(plan.seed)
    golden = (np.sqrt(5.0) - 1.0) / 2.0
    near, far = plan.standoff_m
    views = []
    q = np.asarray(q_seed, dtype=float)
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
            if r.success:
                views.append((s, r.q))
                q = r.q
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


def measure_spheres(
    controller: Controller,
    artifact: SphereArtifact,
    plan: CalibrationPlan,
    progress: Progress | None = None,
    on_view: Callable[[], None] | None = None,
) -> SphereMeasurements:
    """Fetch the laser, move the table to the plan's position and view every sphere; points
    within the radius + 10 mm of a sphere's nominal centre (and not on its post) are kept.
    The laser ends back in its slot, put there with the kinematics that fetched it.
    `on_view()` is called with the arm at each view (e.g. to record the cell)."""
    say = progress or (lambda _msg: None)
    viewed = on_view or (lambda: None)
    if controller.tool_in_hand == LASER.name:
        raise CalibrationError(
            "the laser is already in hand: the calibration fetches it from its slot itself "
            "(its mounting on the flange follows from the fetch)"
        )
    q_lock = _fetch_laser(controller)
    controller.move_table(plan.table_position_m)
    T_base_table = nominal_T_base_table(controller.table_position())
    centres = artifact.centres_table @ T_base_table[:3, :3].T + T_base_table[:3, 3]
    kin = controller.kinematics
    T_laser = controller.T_flange_tcp()
    dirs = controller.laser_directions_tcp
    views = plan_views(kin, centres, plan, controller.q_home)
    q_lines, lines, spheres, points = [], [], [], []
    margin = artifact.radius_m + 0.01
    for s, q in views:
        try:
            controller.move_joints(q, settle_s=0.2)
        except CellError as exc:
            raise CalibrationError(f"a calibration view of sphere {s + 1} failed: {exc}") from exc
        viewed()
        # The arm stands still: the lines of a view are averaged ray by ray.
        readings = [controller.read_laser() for _ in range(plan.lines_per_view)]
        ranges = np.array([r.distances for r in readings])
        index = np.flatnonzero(np.all(np.isfinite(ranges), axis=0))
        q_view = np.mean([r.q_measured for r in readings], axis=0)
        p_laser = dirs[index] * ranges[:, index].mean(axis=0)[:, None]
        T = kin.fk(q_view) @ T_laser
        rel = p_laser @ T[:3, :3].T + T[:3, 3] - centres[s]
        keep = (np.linalg.norm(rel, axis=1) < margin) & (rel[:, 2] > -0.6 * artifact.radius_m)
        if not np.any(keep):
            continue
        q_lines.append(q_view)
        lines.append(np.full(int(keep.sum()), len(q_lines) - 1))
        spheres.append(np.full(int(keep.sum()), s))
        points.append(p_laser[keep])
    say(f"calibration: {len(views)} views of {len(centres)} spheres, {len(q_lines)} lines")
    controller.move_joints(controller.q_home)
    controller.return_tool()
    if not points:
        raise CalibrationError(
            f"no laser point within {margin * 1e3:.0f} mm of any sphere's nominal centre in "
            f"{len(views)} views: is the artifact on the table at {plan.table_position_m} m?"
        )
    return SphereMeasurements(
        np.array(q_lines),
        np.concatenate(lines),
        np.concatenate(spheres),
        np.concatenate(points),
        q_lock,
        controller.T_base_slot(LASER.name),
        LASER.T_tool_tcp,
        centres,
        artifact.radius_m,
        len(views),
    )


# -- identification ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Identification:
    """The fit: deviations (P,) [m, rad] (see cell.robots), sphere centres (S, 3) in the
    base frame [m], point residual RMS with the nominal arm and with the identified one [m]
    (centres fitted for each), inlier points used, Gauss-Newton iterations of both fits."""

    deviations: np.ndarray
    centres_base: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    iterations: int


def points_base(m: SphereMeasurements, kin: Kinematics) -> np.ndarray:
    """(N, 3) the measured points in the base frame [m] for the arm `kin`, with the laser
    mounted where the fetch put it."""
    T_flange_laser = np.linalg.solve(kin.fk(m.q_lock), m.T_base_slot) @ m.T_tool_laser
    T = np.array([kin.fk(q) @ T_flange_laser for q in m.q_lines])[m.line]
    return np.einsum("nij,nj->ni", T[:, :3, :3], m.p_laser) + T[:, :3, 3]


def _residuals(p: np.ndarray, centres: np.ndarray, sphere: np.ndarray, r: float) -> np.ndarray:
    return np.linalg.norm(p - centres[sphere], axis=1) - r


def _fit(
    m: SphereMeasurements,
    robot: Robot,
    use: np.ndarray,
    deviations: np.ndarray,
    centres: np.ndarray,
    free_arm: bool,
    prior: np.ndarray,
    point_sigma_m: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Gauss-Newton on the points `use` (N,) bool: sphere centres, and the arm's deviations
    if `free_arm`, with the prior sigmas (P,) on the deviations."""
    S = len(centres)
    sphere, radius = m.sphere[use], m.radius_m
    dev, c = deviations.copy(), centres.copy()
    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 (the count is returned)
        kin = robot.kinematics(dev)
        p = points_base(m, kin)[use]
        res = _residuals(p, c, sphere, radius)
        n = (p - c[sphere]) / np.linalg.norm(p - c[sphere], axis=1)[:, None]
        J_c = np.zeros((len(p), 3 * S))
        for s in range(S):
            J_c[sphere == s, 3 * s : 3 * s + 3] = -n[sphere == s]
        if free_arm:
            free = np.flatnonzero(robot.identified)
            P = len(free)
            J_d = np.empty((len(p), P))
            for col, j in enumerate(free):
                step = dev.copy()
                step[j] += _STEP
                p_j = points_base(m, robot.kinematics(step))[use]
                J_d[:, col] = np.einsum("ni,ni->n", n, p_j - p) / _STEP
            J = np.hstack([J_d, J_c]) / point_sigma_m
            J = np.vstack([J, np.hstack([np.diag(1.0 / prior[free]), np.zeros((P, 3 * S))])])
            rvec = np.concatenate([res / point_sigma_m, dev[free] / prior[free]])
        else:
            J, rvec = J_c, res
        delta = np.linalg.lstsq(J, -rvec, rcond=None)[0]
        if free_arm:
            dev[free] = dev[free] + delta[:P]
            c = c + delta[P:].reshape(S, 3)
        else:
            c = c + delta.reshape(S, 3)
        if np.max(np.abs(delta)) < 1e-9:
            break
    return dev, c, done


def identify(
    m: SphereMeasurements,
    robot: Robot,
    *,
    prior_sigma_m: float = 1e-3,
    prior_sigma_rad: float = 1e-3,
    point_sigma_m: float = 1e-4,
    max_residual_rms_m: float = 1e-4,
    min_points_per_sphere: int = 200,
    iterations: int = 10,
) -> Identification:
    """Identify the deviations of `robot`'s arm (its model, cell.robots) from the
    measurements.

    The prior (sigmas [m] for lengths, [rad] for offsets) holds the directions the data do
    not see. Points whose residual is beyond 4 robust sigmas (at least 0.3 mm) of a first fit
    are dropped. Raises CalibrationError for too few points on a sphere or a poor fit.
    """
    S = len(m.centres_base)
    counts = np.bincount(m.sphere, minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"points per sphere {counts.tolist()}: each sphere needs at least "
            f"{min_points_per_sphere} laser points"
        )
    prior = robot.sigmas(prior_sigma_m, prior_sigma_rad)
    zero = robot.zero()
    use = np.ones(m.points, dtype=bool)
    dev, c, its_first = _fit(
        m, robot, use, zero, m.centres_base, True, prior, point_sigma_m, iterations
    )
    kin = robot.kinematics(dev)
    res = _residuals(points_base(m, kin), c, m.sphere, m.radius_m)
    sigma = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    use = np.abs(res) <= max(4.0 * sigma, 3e-4)
    counts = np.bincount(m.sphere[use], minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"inlier points per sphere {counts.tolist()} after the first fit: each sphere "
            f"needs at least {min_points_per_sphere}"
        )
    dev, c, its = _fit(m, robot, use, dev, c, True, prior, point_sigma_m, iterations)
    kin_after = robot.kinematics(dev)
    after = _residuals(points_base(m, kin_after)[use], c, m.sphere[use], m.radius_m)
    kin_before = robot.kinematics()
    _, c0, _ = _fit(m, robot, use, zero, c, False, prior, point_sigma_m, iterations)
    before = _residuals(points_base(m, kin_before)[use], c0, m.sphere[use], m.radius_m)
    rms_before = float(np.sqrt(np.mean(before**2)))
    rms_after = float(np.sqrt(np.mean(after**2)))
    if not rms_after <= max_residual_rms_m:
        raise CalibrationError(
            f"the calibration's residual RMS is {rms_after * 1e3:.3f} mm after the fit "
            f"({rms_before * 1e3:.3f} mm before), above the limit of "
            f"{max_residual_rms_m * 1e3:.3f} mm: the spheres or the views are not as planned"
        )
    return Identification(dev, c, rms_before, rms_after, int(use.sum()), its_first + its)


def calibrate(
    controller: Controller,
    artifact: SphereArtifact = DEFAULT_ARTIFACT,
    plan: CalibrationPlan | None = None,
    max_residual_rms_m: float = 1e-4,
    progress: Progress | None = None,
    on_view: Callable[[], None] | None = None,
) -> CalibrationResult:
    """Measure the artifact and identify the arm (see the module's docstring). The
    controller's kinematics is left as it was: the caller decides to use the result."""
    t0 = time.perf_counter()
    plan = plan or CalibrationPlan()
    m = measure_spheres(controller, artifact, plan, progress, on_view)
    robot = controller.robot
    fit = identify(m, robot, max_residual_rms_m=max_residual_rms_m)
    return CalibrationResult(
        robot.kinematics(fit.deviations),
        robot.parameters,
        fit.deviations,
        fit.centres_base,
        fit.residual_rms_before_m,
        fit.residual_rms_after_m,
        fit.points,
        m.views,
        fit.iterations,
        time.perf_counter() - t0,
    )
