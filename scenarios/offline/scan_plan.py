"""Scan planning aimed at the targets: candidate passes simulated in the virtual cell, chosen
for the worst predicted target error per second of scan.

Each candidate is a straight pass (`ScanPass`: tilt, heading, aim offset) around the object's
upper hemisphere and sides. It is kept if the arm follows it at some table position and the
laser clears the object and the cell along it; then its lines are ray cast in the virtual
cell (the nominal model at its believed pose, the laser's data sheet: rays, range, grazing
limit) for the surface it would see, and its cell time is its sweep plus the arm's moves to
and from it.

The planner adds passes greedily: at each step the one that lowers the worst predicted TRE
at the operation targets most per second of its cell time. The predicted TRE is the
registration's (registration.quality.pose_covariance): the point-to-plane information of the
points the passes would see, thinned as the match thins them, with correlated model error
and each pass's rigid offset (the arm's accuracy) from the configuration's data-sheet
numbers. It stops when every target is below the goal or the time budget is spent. A target
that no reachable pass set constrains below the goal is said so: the job refuses before any
motion. The moves between the chosen passes are checked in the virtual cell too: one that
would bring the arm or the laser against the object goes through home.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from cell import Kinematics, nominal_T_base_table
from cell.controller import SETTLE_S
from cell.trajectory import QUINTIC_PEAK
from cell.virtual import VirtualCell
from models.robot import LASER, TABLE_SPEED
from registration import transform_points
from registration.quality import ResidualCorrelation, ScanPasses, pose_covariance, predicted_tre
from registration.rigid import invert
from scenarios.offline.localization import voxel_thin
from scenarios.offline.moves import TABLE_CANDIDATES_M, UnreachablePlanError
from scenarios.offline.premotion import joint_move_samples
from scenarios.offline.premotion_verdict import PremotionLimits
from scenarios.offline.scan import (
    RETREAT_M,
    RETREAT_SPEED_M_S,
    ObjectBox,
    PlannedPass,
    plan_pass,
    risen,
)
from scenarios.offline.scan import plan_scan as plan_scan_fixed
from scenarios.offline.settings import Scan, ScanPass
from scenarios.results.scan_plan import PassSummary, ScanPlanSummary

Progress = Callable[[str], None]

#: Laser lines [m] apart along a candidate's sweep in its prediction (the real pass reads
#: one every speed x period, about 1 mm: the prediction needs the surface, not the density).
PREDICT_LINE_SPACING_M = 0.004
#: Every n-th ray of the fan in the prediction.
PREDICT_RAY_STRIDE = 4
#: Samples of a candidate's line checked for collisions in the virtual cell.
COLLISION_SAMPLES = 5


class ScanPlanError(UnreachablePlanError):
    """No plan reaches the goal: a target that no reachable pass constrains."""


class TransitError(ScanPlanError):
    """No clear way to the start of the plan's pass `index`, directly or through home."""

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.index = index
        #: The candidates the routed plan was made of, in its order (None: not a chosen plan).
        self.plan: tuple[Candidate, ...] | None = None


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


@dataclass(frozen=True)
class ChosenPass:
    """A chosen pass: its name, parameters (`standoff_m` None: the scan's own), the worst
    predicted TRE [m] once it is added, its cell time [s] and its share of the plan's
    information (the trace of the information matrix it adds, over the plan's)."""

    name: str
    tilt_deg: float
    heading_deg: float
    offset_m: float
    standoff_m: float | None
    table_position_m: float
    predicted_tre_max_m: float
    seconds: float
    information_share: float


@dataclass(frozen=True, eq=False)
class ScanPlan:
    """The plan a job scans with: its mode ("auto" or "fixed"), its passes, the predicted
    cell time of the scan [s], the predicted TRE at each target (K,) [m], the chosen passes
    in order, and the candidates considered (auto)."""

    mode: str
    passes: tuple[PlannedPass, ...]
    predicted_time_s: float
    predicted_tre_m: np.ndarray
    chosen: tuple[ChosenPass, ...]
    candidates: tuple[Candidate, ...] = ()
    speed_m_s: float = 0.1
    #: The points (M_k, 3) each chosen pass is predicted to see, in the model frame.
    seen_model: tuple[np.ndarray, ...] = ()
    #: The scan's own stand-off [m] (that of a pass without one of its own).
    standoff_m: float = 0.28

    @property
    def specs(self) -> tuple[ScanPass, ...]:
        """The chosen passes' parameters, in scan order."""
        return tuple(
            ScanPass(
                tilt_deg=c.tilt_deg, heading_deg=c.heading_deg, offset_m=c.offset_m,
                standoff_m=c.standoff_m,
            )
            for c in self.chosen
        )  # fmt: skip

    def summary(self, scan_time_s: float | None) -> ScanPlanSummary:
        """What results.json keeps of the plan: `scan_time_s` is the cell time the scan took
        [s] (None: it did not run)."""
        return ScanPlanSummary(
            mode=self.mode,
            passes=len(self.passes),
            sweep_speed_m_s=self.speed_m_s,
            scan_time_s=scan_time_s,
            predicted_scan_time_s=self.predicted_time_s,
            predicted_tre_max_m=self.predicted_tre_max_m,
            predicted_tre_m=tuple(float(t) for t in self.predicted_tre_m),
            candidates=len(self.candidates),
            chosen=tuple(
                PassSummary(
                    name=c.name,
                    tilt_deg=c.tilt_deg,
                    heading_deg=c.heading_deg,
                    offset_m=c.offset_m,
                    standoff_m=self.standoff_m if c.standoff_m is None else c.standoff_m,
                    table_position_m=c.table_position_m,
                    predicted_tre_max_m=None
                    if not np.isfinite(c.predicted_tre_max_m)
                    else c.predicted_tre_max_m,
                    seconds=c.seconds,
                    information_share=c.information_share,
                    through_home=bool(p.q_via),
                )
                for c, p in zip(self.chosen, self.passes, strict=True)
            ),
        )

    @property
    def predicted_tre_max_m(self) -> float:
        return float(np.max(self.predicted_tre_m)) if len(self.predicted_tre_m) else 0.0


@dataclass(frozen=True)
class ErrorModel:
    """What the planner predicts the scan's errors to be (data-sheet numbers): white range
    noise [m], correlated model error [m] and its correlation length [m], each pass's rigid
    offset per axis [m]; points thinned to one per `voxel_m` cube, at most `max_points`."""

    sigma_white_m: float
    sigma_correlated_m: float
    correlation_m: float
    pass_sigma_m: float
    voxel_m: float
    max_points: int


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


def _joint_move_s(q_from: np.ndarray, q_to: np.ndarray, joint_speed: np.ndarray) -> float:
    """Cell time [s] of a joint move and its settling: the controller's quintic profile,
    the slowest joint at its speed limit at the peak."""
    dq = np.abs(np.asarray(q_to) - np.asarray(q_from))
    return float(np.max(QUINTIC_PEAK * dq / joint_speed)) + SETTLE_S


def _line_s(length_m: float, speed_m_s: float) -> float:
    """Cell time [s] of a straight move of `length_m` [m] at `speed_m_s` and its settling."""
    return QUINTIC_PEAK * length_m / speed_m_s + SETTLE_S


def pass_seconds(planned: PlannedPass, section: Scan) -> float:
    """Cell time [s] of a pass itself: its sweep and the laser's rise after it."""
    length = float(np.linalg.norm(planned.T_table_end[:3, 3] - planned.T_table_start[:3, 3]))
    return _line_s(length, section.speed_m_s) + _line_s(RETREAT_M, RETREAT_SPEED_M_S)


def scan_seconds(
    passes: tuple[PlannedPass, ...] | list[PlannedPass],
    section: Scan,
    q_home: np.ndarray,
    joint_speed: np.ndarray,
) -> float:
    """Predicted cell time [s] of the scan motions: from home, each pass' table move, the
    joint moves through its via points to its start (from the previous pass' start: the
    rise and the sweep are short beside the arm's turns), the pass."""
    total, q, s = 0.0, np.asarray(q_home), 0.0
    for p in passes:
        if abs(p.table_position_m - s) > 1e-9:
            total += _line_s(abs(p.table_position_m - s), TABLE_SPEED)
            s = p.table_position_m
        for q_next in (*p.q_via, p.q_start):
            total += _joint_move_s(q, q_next, joint_speed)
            q = q_next
        total += pass_seconds(p, section)
    return total


#: How finely a transit is checked: the pre-motion check's steps (TCP travel, joint angle).
TRANSIT_LIMITS = PremotionLimits()


def _retreat_q(
    kin: Kinematics, planned: PlannedPass, T_base_table: Callable[[float], np.ndarray]
) -> np.ndarray | None:
    """The joints (6,) at the end of a pass after the laser's rise (as the scan runs it:
    RETREAT_M up, or half of it), or None if the arm does not follow."""
    T_base = T_base_table(planned.table_position_m)
    end = kin.ik(T_base @ planned.T_table_end, planned.q_start, LASER.T_tool_tcp, extra_seeds=4)
    if not end.success:
        return None
    for T_up in risen(T_base @ planned.T_table_end):
        up = kin.ik(T_up, end.q, LASER.T_tool_tcp, extra_seeds=0)
        if up.success:
            return up.q
    return end.q


def _pose_clear(cell: VirtualCell, q: np.ndarray, table_m: float, margin_m: float) -> bool:
    """Whether the arm with the laser at joints `q` (6,), the table at `table_m` [m], keeps
    `margin_m` [m] from everything in the virtual cell."""
    cell.set_tool("laser")
    cell.set_table(table_m)
    cell.set_joints(q)
    return not cell.contacts(margin_m)


Poses = list[tuple[np.ndarray, float]]


def _joint_move_poses(kin: Kinematics, q0: np.ndarray, q1: np.ndarray, table_m: float) -> Poses:
    """The poses (joints, table position [m]) of the joint move q0 -> q1 (straight in joint
    space, as the controller moves) with the table at `table_m`, sampled as the pre-motion
    check samples a joint move (q0 itself not among them)."""
    limits = TRANSIT_LIMITS
    steps = joint_move_samples(kin, LASER.T_tool_tcp, q0, q1, limits.step_m, limits.step_rad)
    return [(q0 + f * (q1 - q0), table_m) for f in steps]


def _table_travel_poses(q: np.ndarray, s0: float, s1: float) -> Poses:
    """The poses of the arm held at `q` while the table moves from `s0` to `s1` [m]: every
    2 cm of the travel, both ends included."""
    steps = max(1, int(np.ceil(abs(s1 - s0) / 0.02))) + 1
    return [(q, float(s)) for s in np.linspace(s0, s1, steps)]


def _poses_clear(cell: VirtualCell, poses: Poses, margin_m: float) -> bool:
    """Whether the arm with the laser keeps `margin_m` [m] from everything at each pose."""
    return all(_pose_clear(cell, q, s, margin_m) for q, s in poses)


def _blocker(cell: VirtualCell, legs: tuple[tuple[str, Poses], ...], margin_m: float) -> str:
    """What the first of the named `legs` to meet the cell first comes within `margin_m` [m]
    of: "link5 within 4 mm of table (home -> pass start)"."""
    for name, poses in legs:
        for q, s in poses:
            cell.set_tool("laser")
            cell.set_table(s)
            cell.set_joints(q)
            found = cell.contacts(margin_m)
            if found:
                c = found[0]
                how = "into" if c.penetrating else f"within {c.distance_m * 1e3:.0f} mm of"
                return f"{c.body} {how} {c.other} ({name})"
    return "nothing found on the way through home"


def route_transits(
    cell: VirtualCell,
    kin: Kinematics,
    passes: tuple[PlannedPass, ...],
    q_home: np.ndarray,
    T_base_table: Callable[[float], np.ndarray] = nominal_T_base_table,
    margin_m: float = 0.01,
) -> tuple[PlannedPass, ...]:
    """The passes with their transits checked in the virtual cell, as the scan runs them:
    from home to the first start, and from each pass' end, the laser risen, to the next
    start (the table moved first, the arm held where it rose). A transit that comes within
    `margin_m` [m] of anything goes through home instead (the table moving with the arm
    there); if that does not clear either, TransitError names the pass."""
    out: list[PlannedPass] = []
    home = np.asarray(q_home, dtype=float)
    q_from, s_from = home, passes[0].table_position_m if passes else 0.0
    for index, planned in enumerate(passes):
        s = planned.table_position_m
        direct = _table_travel_poses(q_from, s_from, s) + _joint_move_poses(
            kin, q_from, planned.q_start, s
        )
        via: tuple[np.ndarray, ...] = ()
        if not _poses_clear(cell, direct, margin_m):
            legs = (
                ("the move to home", _joint_move_poses(kin, q_from, home, s_from)),
                ("the table's travel at home", _table_travel_poses(home, s_from, s)),
                ("home -> pass start", _joint_move_poses(kin, home, planned.q_start, s)),
            )
            if not all(_poses_clear(cell, poses, margin_m) for _, poses in legs):
                raise TransitError(
                    f"scan plan: no clear way to {planned.name}: the arm's move to its start "
                    f"comes within {margin_m * 1e3:.0f} mm of the cell, directly and through "
                    f"home ({_blocker(cell, legs, margin_m)}); the job refuses before any "
                    "motion. Give the arm a home above the object from which the pass' start "
                    "is clear (cell.robot.home_deg), a joint window that keeps the elbow and "
                    "wrist on one branch (cell.robot.limits_deg), or move the arm "
                    "(cell.robot.mount_xyz) or the object (cell.object.placement.xy_m) so "
                    "that the pass lies within easier reach",
                    index,
                )
            via = (home,)
        out.append(replace(planned, q_via=via))
        q_from, s_from = _risen(kin, planned, T_base_table), s
    return tuple(out)


def _risen(
    kin: Kinematics, planned: PlannedPass, T_base_table: Callable[[float], np.ndarray]
) -> np.ndarray:
    """The joints the arm leaves pass `planned` with: the laser risen from its end, or its
    start where it cannot rise."""
    rose = _retreat_q(kin, planned, T_base_table)
    return planned.q_start if rose is None else rose


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
    object in the virtual cell."""
    cell.set_table(planned.table_position_m)
    T_world_table = cell.T_world_site("table_top")
    p0, p1 = planned.T_table_start[:3, 3], planned.T_table_end[:3, 3]
    n_lines = max(2, int(np.ceil(np.linalg.norm(p1 - p0) / PREDICT_LINE_SPACING_M)) + 1)
    R = T_world_table[:3, :3] @ planned.T_table_start[:3, :3]
    dirs = dirs_tcp[::PREDICT_RAY_STRIDE] @ R.T
    cos_max = np.cos(max_incidence_rad)
    points, normals = [], []
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


def _clear(
    cell: VirtualCell,
    kin: Kinematics,
    planned: PlannedPass,
    T_base_table: Callable[[float], np.ndarray],
    margin_m: float,
) -> bool:
    """Whether the arm with the laser follows the pass' line clear of everything by
    `margin_m` [m] in the virtual cell (checked at COLLISION_SAMPLES points)."""
    cell.set_tool("laser")
    cell.set_table(planned.table_position_m)
    T_base = T_base_table(planned.table_position_m)
    q = planned.q_start
    p0, p1 = planned.T_table_start[:3, 3], planned.T_table_end[:3, 3]
    for s in np.linspace(0.0, 1.0, COLLISION_SAMPLES):
        T = planned.T_table_start.copy()
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
    found = []
    specs = candidate_specs(where.box, section)
    for i, spec in enumerate(specs):
        try:
            planned = plan_pass(kin, where.box, section, spec, i, q_home, where.T_base_table)
        except UnreachablePlanError:
            continue
        if not _clear(cell, kin, planned, where.T_base_table, margin_m):
            continue
        p, n = where.predict(planned)
        if len(p) < 50:
            continue
        # Its own time and the arm's turn to it from home and back: what adding it costs.
        seconds = pass_seconds(planned, section) + 2.0 * _joint_move_s(
            q_home, planned.q_start, where.joint_speed
        )
        found.append(Candidate(spec, planned, p, n, seconds))
    return tuple(found), len(specs)


def predict_tre(
    chosen: list[Candidate], targets_model: np.ndarray, errors: ErrorModel
) -> tuple[np.ndarray, np.ndarray]:
    """The predicted TRE (K,) [m] at `targets_model` (K, 3) from the points the `chosen`
    passes would see, and the information matrix (6, 6) they give (per unit variance)."""
    if not chosen:
        return np.full(len(targets_model), np.inf), np.zeros((6, 6))
    points = np.concatenate([c.points_model for c in chosen])
    normals = np.concatenate([c.normals_model for c in chosen])
    labels = np.concatenate([np.full(len(c.points_model), k) for k, c in enumerate(chosen)])
    keep = voxel_thin(points, errors.voxel_m)
    # The match draws at most max_points of the thinned points: so many carry its information.
    scale = min(1.0, errors.max_points / max(len(keep), 1))
    p, n, lab = points[keep], normals[keep], labels[keep]
    J = np.hstack([n, np.cross(p, n)])
    info = scale * (J.T @ J)
    if len(p) < 6 or np.linalg.cond(info) > 1e12:
        return np.full(len(targets_model), np.inf), info
    weights = np.full(len(p), scale)
    correlation = ResidualCorrelation(
        errors.sigma_white_m, errors.sigma_correlated_m, errors.correlation_m
    )
    passes = ScanPasses(lab, errors.pass_sigma_m) if errors.pass_sigma_m > 0 else None
    cov = pose_covariance(p, n, weights, errors.sigma_white_m, correlation, passes)
    return predicted_tre(cov, targets_model), info


def information_shares(
    passes: list[Candidate], targets_model: np.ndarray, errors: ErrorModel
) -> list[float]:
    """Each pass' share of the plan's information: the trace of the information matrix its
    points add to the others' (after thinning), normalized to sum to one."""
    _, total = predict_tre(passes, targets_model, errors)
    shares = []
    for k in range(len(passes)):
        _, without = predict_tre(passes[:k] + passes[k + 1 :], targets_model, errors)
        shares.append(max(float(np.trace(total) - np.trace(without)), 0.0))
    norm = sum(shares) or 1.0
    return [s / norm for s in shares]


def _best_candidate(
    chosen: list[Candidate],
    left: list[Candidate],
    tre: np.ndarray,
    spent_s: float,
    budget_s: float,
    targets_model: np.ndarray,
    errors: ErrorModel,
) -> tuple[Candidate | None, np.ndarray, float]:
    """The candidate among `left` that lowers the worst predicted TRE most per second of
    cell time added to `chosen` (predicted TRE (K,) [m] now `tre`; while nothing constrains
    every target, the one that sees most per second), within `budget_s` [s] with `spent_s`
    spent once a pass is chosen: it (None if none fits), the predicted TRE with it, and the
    most any one pass lowers the worst predicted TRE [m]."""
    best, best_gain, best_tre = None, -np.inf, tre
    worst_now = float(np.max(tre))
    largest_drop = 0.0
    for c in left:
        if chosen and spent_s + c.seconds > budget_s:
            continue
        t, _ = predict_tre([*chosen, c], targets_model, errors)
        worst = float(np.max(t))
        if np.isfinite(worst) and np.isfinite(worst_now):
            largest_drop = max(largest_drop, worst_now - worst)
        if not np.isfinite(worst):
            gain = -np.inf if np.isfinite(worst_now) else len(c.points_model) / c.seconds
            gain = gain * 1e-12  # constrains nothing yet: coverage first
        elif not np.isfinite(worst_now):
            gain = 1.0 / (worst * c.seconds)
        else:
            gain = (worst_now - worst) / c.seconds
        if gain > best_gain:
            best, best_gain, best_tre = c, gain, t
    return best, best_tre, largest_drop


def choose_passes(
    found: tuple[Candidate, ...],
    targets_model: np.ndarray,
    errors: ErrorModel,
    goal_m: float,
    budget_s: float,
    say: Progress | None = None,
    unambiguous: Callable[[list[Candidate]], bool] | None = None,
    min_gain: float = 0.0,
) -> tuple[list[Candidate], list[ChosenPass], np.ndarray, bool]:
    """Greedy choice (see the module's docstring): the passes, their records, the predicted
    TRE (K,) [m] of the plan, and whether `unambiguous(passes)` holds for it (the match of
    the points they would see finds one pose; passes are added until it does). Short of
    the goal, the choice also stops when no pass lowers the worst predicted TRE by the
    fraction `min_gain` of it: more scanning would buy next to nothing."""
    chosen: list[Candidate] = []
    records: list[ChosenPass] = []
    tre = np.full(len(targets_model), np.inf)
    spent = 0.0
    left = list(found)
    unique = False

    def done() -> bool:
        nonlocal unique
        if not chosen or np.max(tre) > goal_m:
            return False
        unique = unambiguous is None or unambiguous(chosen)
        if not unique and say is not None:
            say("scan plan: the match of what these passes see is ambiguous: one more pass")
        return unique

    while left and not done():
        worst_now = float(np.max(tre))
        best, best_tre, largest_drop = _best_candidate(
            chosen, left, tre, spent, budget_s, targets_model, errors
        )
        if best is None:
            break
        if np.isfinite(worst_now) and worst_now > goal_m and largest_drop < min_gain * worst_now:
            if say is not None:
                say(
                    f"scan plan: no pass lowers the worst predicted TRE by {min_gain:.0%} any "
                    "more: the plan stops here"
                )
            break
        chosen.append(best)
        left.remove(best)
        spent += best.seconds
        tre = best_tre
        records.append(
            ChosenPass(
                best.planned.name,
                best.spec.tilt_deg,
                best.spec.heading_deg,
                best.spec.offset_m,
                best.spec.standoff_m,
                best.planned.table_position_m,
                float(np.max(tre)),
                best.seconds,
                0.0,
            )
        )
        if say is not None:
            say(
                f"scan plan: + {best.planned.name}: worst predicted TRE "
                f"{np.max(tre) * 1e3:.3f} mm, {spent:.0f} s"
            )
    shares = information_shares(chosen, targets_model, errors)
    records = [
        ChosenPass(**{**r.__dict__, "information_share": s})
        for r, s in zip(records, shares, strict=True)
    ]
    if not unique and chosen:
        unique = unambiguous is None or unambiguous(chosen)
    return chosen, records, tre, unique


def error_model(section: Scan, voxel_m: float, max_points: int, pass_sigma_m: float) -> ErrorModel:
    """The planner's error model from the configuration's data-sheet numbers."""
    p = section.planning
    return ErrorModel(
        p.range_sigma_m, p.model_error_m, p.correlation_m, pass_sigma_m, voxel_m, max_points
    )


def plan_job_scan(
    where: PlanningCell,
    section: Scan,
    errors: ErrorModel,
    targets_model: np.ndarray,
    say: Progress | None = None,
    unambiguous: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    target_names: tuple[str, ...] | None = None,
    acceptable_tre_m: float | None = None,
) -> ScanPlan:
    """The job's scan plan in the virtual cell `where`: in mode "auto" chosen among the
    candidates for `targets_model` (K, 3, model frame); in mode "fixed" the configuration's
    passes, with the same prediction. `unambiguous(points_table (N, 3), pass_labels (N,))`:
    whether the match of such a scan finds one pose. Raises ScanPlanError if "auto" leaves a
    target (named by `target_names`) unconstrained, or above the goal and above
    `acceptable_tre_m` [m] (what the match accepts; None: above the goal refuses), or the
    match ambiguous. A plan short of the goal but within `acceptable_tre_m` is scanned, and
    said so."""
    tell = say or (lambda _m: None)
    if section.plan == "fixed":
        return _fixed_plan(where, section, errors, targets_model)
    speed = section.planning.sweep_speed_m_s or min(0.5, errors.voxel_m / section.period_s)
    if errors.voxel_m <= 0 and section.planning.sweep_speed_m_s is None:
        speed = section.speed_m_s
    section = section.model_copy(update={"speed_m_s": speed})
    found_all, tried = candidates(where, section)
    tell(
        f"scan plan: {len(found_all)} of {tried} candidate passes reachable, clear and "
        "seeing the object"
    )

    def is_unique(passes: list[Candidate]) -> bool:
        if unambiguous is None:
            return True
        points = np.concatenate([c.points_model for c in passes])
        labels = np.concatenate([np.full(len(c.points_model), k) for k, c in enumerate(passes)])
        return unambiguous(transform_points(where.T_table_object, points), labels)

    # A picked pass the arm finds no clear way to (routed only once the plan is chosen) is
    # left out of the candidates, and the passes are chosen again without it.
    usable_now = found_all
    while True:
        try:
            return _choose_plan(
                where, section, errors, targets_model, usable_now, tried, tell, is_unique,
                target_names, acceptable_tre_m,
            )  # fmt: skip
        except TransitError as blocked:
            if blocked.plan is None or len(usable_now) <= 1:
                raise
            left_out = blocked.plan[blocked.index]
            tell(f"scan plan: no clear way to {left_out.planned.name}: chosen again without it")
            usable_now = tuple(c for c in usable_now if c is not left_out)


def _choose_plan(
    where: PlanningCell,
    section: Scan,
    errors: ErrorModel,
    targets_model: np.ndarray,
    found_all: tuple[Candidate, ...],
    tried: int,
    tell: Progress,
    is_unique: Callable[[list[Candidate]], bool],
    target_names: tuple[str, ...] | None,
    acceptable_tre_m: float | None,
) -> ScanPlan:
    """plan_job_scan's "auto" plan among the candidates `found_all` (of `tried`)."""
    goal = section.planning.goal_tre_m
    budget, min_gain = section.planning.budget_s, section.planning.min_gain
    picked, records, tre, unique = choose_passes(
        found_all, targets_model, errors, goal, budget, tell, is_unique, min_gain
    )
    names = target_names or tuple(f"target {k + 1}" for k in range(len(targets_model)))
    usable = f"{len(found_all)} of {tried} candidate passes reachable, clear and seeing the object"
    if not picked or not np.all(np.isfinite(tre)):
        free = [names[k] for k in np.flatnonzero(~np.isfinite(tre))] if picked else list(names)
        raise ScanPlanError(
            f"scan plan: no reachable pass constrains {', '.join(free)} ({usable}); the job "
            "refuses before any motion"
        )
    if np.max(tre) > goal:
        over_goal = _over_goal(picked, found_all, tre, names, usable, section)
        if acceptable_tre_m is None or np.max(tre) > acceptable_tre_m:
            limit = (
                ""
                if acceptable_tre_m is None
                else f" and above the {acceptable_tre_m * 1e3:.3f} mm the match accepts "
                "(localization.registration.max_predicted_tre_m)"
            )
            raise ScanPlanError(f"scan plan: {over_goal}{limit}; the job refuses before any motion")
        tell(
            f"warning: scan plan: {over_goal}; the job scans the {len(picked)} passes that "
            f"get there (the match accepts up to {acceptable_tre_m * 1e3:.3f} mm)"
        )
    if not unique:
        raise ScanPlanError(
            f"scan plan: the match of what the {len(picked)} picked passes would see is "
            f"still ambiguous within the {section.planning.budget_s:g} s budget (a rival "
            "pose or a symmetry fits as well); the job refuses before any motion"
        )
    try:
        return _auto_plan(where, section, picked, records, tre, found_all)
    except TransitError as blocked:
        blocked.plan = tuple(picked)
        raise


def _fixed_plan(
    where: PlanningCell, section: Scan, errors: ErrorModel, targets_model: np.ndarray
) -> ScanPlan:
    """The configuration's passes (scan.plan "fixed") routed in the virtual cell, with the
    predicted TRE at `targets_model` (K, 3, model frame) of the plan and of each pass
    added in turn, and each pass' share of the information."""
    kin, q_home, T_base_table = where.kin, where.q_home, where.T_base_table
    passes = route_transits(
        where.cell, kin, plan_scan_fixed(kin, where.box, section, q_home, T_base_table),
        q_home, T_base_table,
    )  # fmt: skip
    found = []
    for spec, planned in zip(section.passes, passes, strict=True):
        p, n = where.predict(planned)
        found.append(Candidate(spec, planned, p, n, pass_seconds(planned, section)))
    tre, _ = predict_tre(found, targets_model, errors)
    shares = information_shares(found, targets_model, errors)
    so_far = [float(np.max(predict_tre(found[: k + 1], targets_model, errors)[0]))
              for k in range(len(found))]  # fmt: skip
    chosen = tuple(
        ChosenPass(
            c.planned.name, c.spec.tilt_deg, c.spec.heading_deg, c.spec.offset_m,
            c.spec.standoff_m, c.planned.table_position_m, worst, c.seconds, share,
        )
        for c, share, worst in zip(found, shares, so_far, strict=True)
    )  # fmt: skip
    seconds = scan_seconds(passes, section, q_home, where.joint_speed)
    return ScanPlan(
        "fixed", passes, seconds, tre, chosen, (), section.speed_m_s,
        tuple(c.points_model for c in found), section.standoff_m,
    )  # fmt: skip


def _over_goal(
    picked: list[Candidate],
    found_all: tuple[Candidate, ...],
    tre: np.ndarray,
    names: tuple[str, ...],
    usable: str,
    section: Scan,
) -> str:
    """What a plan whose predicted TRE (K,) [m] is above the goal at the targets `names`
    says of it: which targets, by how much, and why the choice stopped there (every
    `usable` pass picked, the budget spent, or no pass left gains enough)."""
    goal, budget = section.planning.goal_tre_m, section.planning.budget_s
    over = [f"{names[k]} {tre[k] * 1e3:.3f} mm" for k in np.flatnonzero(tre > goal)]
    spent = sum(c.seconds for c in picked)
    rest = [c.seconds for c in found_all if c not in picked]
    if not rest:
        why = f"every usable pass is in the plan ({usable})"
    elif spent + min(rest) > budget:
        why = f"the {budget:g} s budget is spent"
    else:
        why = f"no further pass lowers it by {section.planning.min_gain:.0%}"
    return (
        f"{', '.join(over)} predicted above the goal {goal * 1e3:.3f} mm "
        f"(localization.scan.planning.goal_tre_m): {why}"
    )


def _auto_plan(
    where: PlanningCell,
    section: Scan,
    picked: list[Candidate],
    records: list[ChosenPass],
    tre: np.ndarray,
    found_all: tuple[Candidate, ...],
) -> ScanPlan:
    """The plan of the `picked` passes (their records, the plan's predicted TRE (K,) [m],
    every candidate considered), re-planned in scan order (alternating sweeps join without
    crossing) and routed in the virtual cell."""
    kin, q_home, T_base_table = where.kin, where.q_home, where.T_base_table
    specs = tuple(c.spec for c in picked)
    passes = route_transits(
        where.cell, kin, plan_scan_fixed(kin, where.box, section, q_home, T_base_table, specs),
        q_home, T_base_table,
    )  # fmt: skip
    return ScanPlan(
        "auto",
        passes,
        scan_seconds(passes, section, q_home, where.joint_speed),
        tre,
        tuple(records),
        found_all,
        section.speed_m_s,
        tuple(c.points_model for c in picked),
        section.standoff_m,
    )


def replan(
    kin: Kinematics,
    box: ObjectBox,
    section: Scan,
    plan: ScanPlan,
    table: Callable[[float], np.ndarray] = nominal_T_base_table,
) -> tuple[PlannedPass, ...]:
    """The plan's passes for the arm and table the cell now believes (`kin`, `table`: the
    calibrated ones): each pass from its planned joints, at its planned table position
    first, through the same via points."""
    out = []
    for k, (spec, planned) in enumerate(zip(plan.specs, plan.passes, strict=True)):
        s = planned.table_position_m
        order = (s, *(p for p in TABLE_CANDIDATES_M if p != s))
        again = plan_pass(kin, box, section, spec, k, planned.q_start, table, order)
        out.append(replace(again, q_via=planned.q_via))
    return tuple(out)
