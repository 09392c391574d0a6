"""Verification after correction: the registration checked on the object before any target
is touched, as a neuronavigation system verifies its registration on landmarks, and as
fine as the job's goal.

After the match, the laser scans again the pass of the scan whose points locate the targets
best (the smallest worst predicted target error from its points alone), at the table
position the program will run at (a table that did not go where its readout says shows
there). Both scans of that strip, the first and the second, are matched on their own to the
model from the registered pose; their difference is how far the object moved since the
scan. Where the program's table position is the pass's own (the arm then follows the pass
with the same joints), the arm's and the table's errors, the laser's mounting and the
model's own errors are the same in both scans, so they cancel: what is left is the laser's
noise on the points and the arm's and the table's repeatability, some hundredths of a
millimetre, where either match alone is uncertain by tenths. At another table position the
arm's calibrated accuracy enters as well.

Each target's move is held to what the job's goal leaves: the RMS goal less the error the
job already has at that target (the registration's predicted TRE and the arm's accuracy,
in quadrature), since a move can add to that error in any direction. If the verification's
own uncertainty is too large to tell a move of that size from none, or to surely see one
beyond the goal, it scans the next best strip as well and matches the strips together, up
to `Budget.max_strips`, as long as more points can help (the repeatability stays in the
bound whatever the points); if it still cannot, the run says what size of move it verified
(`Verification.verified_to_m`), and does not call a move that is within its own bound.

The second strip's match is also compared with the registration itself, with what the two
matches' predicted TREs allow (three standard deviations of their difference): a scan whose
points were wrong shows there.

A strip, not a few small patches: a skull's vault is nearly a sphere, and patches of it see
a turn about its centre not at all; a strip across the face and the vault sees every motion
that moves the targets.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from cell import Controller
from models.model import ObjectModel
from models.robot import LASER
from registration import Acceptance, MeshModel, invert, transform_points
from registration.quality import ScanPasses
from scenarios.offline.cell_model import CellModel
from scenarios.offline.localization import localize
from scenarios.offline.scan_passes import (
    ObjectBox,
    PlannedPass,
    ScanData,
    choose_table_position,
    crop_to_object,
    execute_scan,
)
from scenarios.offline.settings import Scan
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M
from scenarios.results.verification_result import TargetCheck, Verification

Progress = Callable[[str], None]
#: Least allowed difference between the strip's match and the registration at a target [m]:
#: below it, the two matches agree within what the laser alone resolves.
FLOOR_M = 3.0e-4
#: Points of a strip the matches use at most.
STRIP_POINTS = 3000
#: A move's bound: this many standard deviations of the measured move (about 95 % of the
#: noise lies below it, whatever its shape across the three axes).
BOUND_SIGMAS = 2.0
#: Points a re-scanned strip must have on the object to be matched.
MIN_POINTS = 100


def target_covariances(
    points_table: np.ndarray,
    shape: MeshModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
) -> np.ndarray:
    """(K, 3, 3) the covariance of each target's place (per unit point noise) from points
    (N, 3) of the object at its pose T_table_object alone: the point-to-plane information
    of the points, propagated to each target (K, 3, model frame); inf where the points do
    not fix the pose."""
    K = len(targets_model)
    p = transform_points(invert(T_table_object), points_table)
    closest = shape.closest(p)
    if closest.normals is None or len(p) < 6:
        return np.full((K, 3, 3), np.inf)
    n = closest.normals
    J = np.hstack([n, np.cross(closest.points, n)])
    info = J.T @ J
    if np.linalg.cond(info) > 1e12:
        return np.full((K, 3, 3), np.inf)
    cov = np.linalg.inv(info)
    A = np.concatenate(
        [np.broadcast_to(np.eye(3), (K, 3, 3)), -np.array([_skew(t) for t in targets_model])],
        axis=2,
    )  # (K, 3, 6): a target's motion under (translation, rotation)
    return A @ cov @ A.transpose(0, 2, 1)


def target_spread(
    points_table: np.ndarray,
    shape: MeshModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
) -> float:
    """The worst target's predicted error [m] (per unit point noise) from points (N, 3) of
    the object at its pose T_table_object alone (see target_covariances)."""
    C = target_covariances(points_table, shape, T_table_object, np.asarray(targets_model))
    return float(np.sqrt(np.max(np.trace(C, axis1=1, axis2=2))))


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rank_strips(
    scan: ScanData,
    keep: np.ndarray,
    shape: MeshModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
) -> tuple[int, ...]:
    """The passes of `scan` (its object points `keep` (N,)), best first: by how well their
    points alone locate the targets."""
    point_pass = scan.line_pass[scan.line_index][keep]
    points = scan.points_table[keep]
    spreads = {
        int(k): target_spread(points[point_pass == k], shape, T_table_object, targets_model)
        for k in np.unique(point_pass)
    }
    return tuple(sorted(spreads, key=lambda k: spreads[k]))


@dataclass(frozen=True, eq=False)
class RegisteredTargets:
    """The registration to verify: the object's pose T_table_object (4, 4) [m] in the nominal
    table frame, the operation targets (name, point (3,) in the model frame), the
    registration's predicted TRE at each (K,) [m], and the goal's allowance for a move at
    each (K,) [m] (see `allowances`)."""

    T_table_object: np.ndarray
    targets: tuple[tuple[str, np.ndarray], ...]
    predicted_tre_m: np.ndarray
    allowance_m: np.ndarray


def allowances(goal_rms_m: float | None, predicted_tre_m: np.ndarray, arm_m: float) -> np.ndarray:
    """(K,) what the job's RMS goal [m] leaves for a move of each target: the goal less the
    error already there (the registration's predicted TRE (K,) [m] and the arm's accuracy
    [m], independent, in quadrature); a move adds to that error in any direction. Without a
    goal, three predicted TREs."""
    tre = np.asarray(predicted_tre_m, dtype=float)
    if goal_rms_m is None:
        return 3.0 * np.hypot(tre, arm_m)
    return goal_rms_m - np.hypot(tre, arm_m)


@dataclass(frozen=True)
class Budget:
    """What the verification holds a move to and knows of its own noise: the job's RMS goal
    [m] (None: no goal), the laser's range noise [m], the arm's and the table's pose
    repeatability per axis [m], the arm's accuracy while it scans (a pass's offset per
    axis [m], for the strips' matches), the strips it may scan at most, and the arm's
    accuracy after calibration [m] (what a strip scanned again at another table position,
    with other joints, differs by besides)."""

    goal_rms_m: float | None
    range_sigma_m: float
    repeatability_m: float
    pass_sigma_m: float
    max_strips: int
    arm_accuracy_m: float


@dataclass(frozen=True, eq=False)
class ScanRecord:
    """The scan the registration was made on: what the laser measured, which of its points
    (N,) were kept as the object's, and the passes it ran."""

    scan: ScanData
    keep: np.ndarray
    plan: tuple[PlannedPass, ...]

    def pass_points(self, k: int) -> np.ndarray:
        """(M, 3) the object points [m] of pass `k`, in the table frame."""
        point_pass = self.scan.line_pass[self.scan.line_index][self.keep]
        return self.scan.points_table[self.keep][point_pass == k]


@dataclass(frozen=True, eq=False)
class StripMatch:
    """Points of one or more strips (N, 3) [m] with their strip (N,), matched alone."""

    points: np.ndarray
    labels: np.ndarray
    T_table_object: np.ndarray
    tre_m: np.ndarray
    covariance: np.ndarray  # (K, 3, 3) per unit point noise


def _match_strips(
    points: np.ndarray,
    labels: np.ndarray,
    shape: MeshModel,
    T_prior: np.ndarray,
    targets_model: np.ndarray,
    pass_sigma_m: float,
) -> StripMatch:
    located = localize(
        points,
        shape,
        STRIP_POINTS,
        Acceptance(),
        0,
        mode="refine",
        T_table_object_prior=T_prior,
        passes=ScanPasses(labels, pass_sigma_m),
    )
    T = located.T_table_object
    cov = target_covariances(points, shape, T, targets_model)
    cov = cov * max(1.0, len(points) / STRIP_POINTS)  # the match uses a subsample
    tre = located.result.predicted_tre(targets_model).tre
    return StripMatch(points, labels, T, tre, cov)


@dataclass(frozen=True, eq=False)
class Rescanned:
    """The verification and the strips' points (N, 3) [m] in the table frame as scanned
    again."""

    verification: Verification
    points_table: np.ndarray


def verify_registration(
    controller: Controller,
    virtual: ObjectModel,
    registered: RegisteredTargets,
    scanned: ScanRecord,
    box: ObjectBox,
    section: Scan,
    table_position_m: float,
    model: CellModel,
    budget: Budget,
    say: Progress,
) -> Rescanned:
    """Scan strips of the object again and measure how far it moved (see the module's
    docstring): the passes of `scanned` best first, each scanned again with the cell's
    `model` at `table_position_m` [m] (the program's) if the arm follows it there, until
    every target's check is resolved or `budget.max_strips` ran."""
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    targets_model = np.array([p for _, p in registered.targets])
    ranked = rank_strips(
        scanned.scan, scanned.keep, shape, registered.T_table_object, targets_model
    )
    before: list[np.ndarray] = []
    after: list[np.ndarray] = []
    names: list[str] = []
    as_scanned: list[bool] = []
    t0 = controller.time_s
    verification = Verification((), 0, 0.0, ())
    for k in ranked[: budget.max_strips]:
        planned = scanned.plan[k]
        again, same = _rescan(controller, planned, box, section, table_position_m, model, say)
        as_scanned.append(same)
        names.append(planned.name)
        before.append(scanned.pass_points(k))
        after.append(again)
        held = replace(budget, arm_accuracy_m=0.0) if all(as_scanned) else budget
        verification = _checked(
            registered, shape, targets_model, (before, after), tuple(names), held
        )
        verification = replace(verification, scan_time_s=controller.time_s - t0)
        if verification.resolved or not verification.agrees or not verification.checks:
            break
        if not _finer_helps(verification, held):
            say(f"verify: {verification.summary()}; more strips cannot make it finer")
            break
        say(f"verify: {verification.summary()}; a finer check: the next strip as well")
    return Rescanned(verification, np.concatenate(after) if after else np.empty((0, 3)))


def _finer_helps(verification: Verification, budget: Budget) -> bool:
    """Whether more strips could resolve every check: more points leave the arm's and the
    table's repeatability (and the arm's accuracy at another table position) in the bound,
    and that must fit within what each target's call needs."""
    floor = BOUND_SIGMAS * np.sqrt(
        2.0 * 3.0 * budget.repeatability_m**2 + 2.0 * budget.arm_accuracy_m**2
    )
    return all(
        c.resolved or (c.allowance_m > 0 and floor <= min(c.allowance_m, c.goal_m - c.allowance_m))
        for c in verification.checks
    )


def _stack(parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    labels = np.concatenate([np.full(len(p), i) for i, p in enumerate(parts)])
    return np.concatenate(parts), labels


def _checked(
    registered: RegisteredTargets,
    shape: MeshModel,
    targets_model: np.ndarray,
    strips: tuple[list[np.ndarray], list[np.ndarray]],
    names: tuple[str, ...],
    budget: Budget,
) -> Verification:
    """Each target's check from the strips' first points and their points again (`strips`:
    before, after), both matched alone from the registered pose."""
    before, after = strips
    points_after, labels_after = _stack(after)
    if min(len(a) for a in after) < MIN_POINTS or min(len(b) for b in before) < MIN_POINTS:
        return Verification(names, len(points_after), 0.0, ())
    T_reg = registered.T_table_object
    sigma = budget.pass_sigma_m
    first = _match_strips(*_stack(before), shape, T_reg, targets_model, sigma)
    second = _match_strips(points_after, labels_after, shape, T_reg, targets_model, sigma)
    # The object's move between the two scans, in the table frame, at each target.
    T_moved = second.T_table_object @ invert(first.T_table_object)
    x = transform_points(T_reg, targets_model)
    moved = np.linalg.norm(transform_points(T_moved, x) - x, axis=1)
    noise = budget.range_sigma_m**2 * (first.covariance + second.covariance)
    variance = (
        np.trace(noise, axis1=1, axis2=2)
        + 2.0 * 3.0 * budget.repeatability_m**2
        + 2.0 * budget.arm_accuracy_m**2
    )
    uncertainty = BOUND_SIGMAS * np.sqrt(variance)
    # The second scan's own match against the registration (a wrong scan shows here).
    apart = np.linalg.norm(transform_points(second.T_table_object, targets_model) - x, axis=1)
    allowed = np.maximum(FLOOR_M, 3.0 * np.hypot(registered.predicted_tre_m, second.tre_m))
    goal = float("inf") if budget.goal_rms_m is None else budget.goal_rms_m
    checks = tuple(
        TargetCheck(name, float(m), float(u), float(a), float(d), float(dl), goal)
        for (name, _), m, u, a, d, dl in zip(
            registered.targets,
            moved,
            uncertainty,
            registered.allowance_m,
            apart,
            allowed,
            strict=True,
        )
    )
    return Verification(names, len(points_after), 0.0, checks)


def _rescan(
    controller: Controller,
    planned: PlannedPass,
    box: ObjectBox,
    section: Scan,
    table_position_m: float,
    model: CellModel,
    say: Progress,
) -> tuple[np.ndarray, bool]:
    """The pass `planned` scanned again at `table_position_m` [m] (the program's) if the arm
    follows it there, else at the first table position it does; as it was scanned (its
    joints) if that is its own table position. The table goes back where it was after.
    Returns the points (M, 3) [m] in the table frame within the object's box, and whether
    the pass was scanned again as it was."""
    order = (table_position_m, *(s for s in TABLE_CANDIDATES_M if s != table_position_m))
    s = table_position_m
    q = planned.q_start
    if abs(s - planned.table_position_m) >= 1e-9:
        s, q = choose_table_position(
            controller.kinematics.for_tool("laser"),
            LASER.T_tool_tcp,
            planned.T_table_start,
            planned.T_table_end,
            controller.read_joints(),
            planned.name,
            model.T_base_table,
            order,
            planned.raster_m,
        )
    same = abs(s - planned.table_position_m) < 1e-9
    if same:  # as it was scanned: its joints and its way there
        strip = replace(planned, T_base_table=model.T_base_table(s))
    else:
        strip = PlannedPass(
            planned.name, planned.T_table_start, planned.T_table_end, s, q,
            model.T_base_table(s), (), planned.raster_m,
        )  # fmt: skip
    table_before = controller.table_position()
    again = execute_scan(controller, (strip,), section, say, model)
    # The table goes back where the scan left it: the tool change that follows is planned
    # with it there (at the program's position the object can stand in its way).
    if abs(controller.table_position() - table_before) > 1e-6:
        controller.move_table(table_before)
    return again.points_table[crop_to_object(again.points_table, box, section.crop_margin_m)], same
