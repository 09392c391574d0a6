"""Verification after correction: the registration checked on the object before any target
is touched, as a neuronavigation system verifies its registration on landmarks.

After the match, the laser scans one strip of the object again, at the table position the
program will run at: the pass of the scan whose points locate the targets best (the smallest
worst predicted target error from its points alone). That strip is matched on its own,
starting from the registered pose, and each target is placed by both poses: if the object
stayed where the scan saw it, the two agree within what the two matches' predicted TREs
allow (three standard deviations of their difference: the model's own error, the laser's
and the arm's in each). A larger difference means the object moved since the scan, or the
scan the match came from was wrong (a table that did not go where its readout says).

A strip, not a few small patches: a skull's vault is nearly a sphere, and patches of it see
a turn about its centre not at all; a strip across the face and the vault sees every motion
that moves the targets.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller
from models.model import ObjectModel
from models.robot import LASER
from registration import Acceptance, MeshModel, invert, transform_points
from registration.quality import ScanPasses
from scenarios.offline.cell_model import CellModel
from scenarios.offline.localization import localize
from scenarios.offline.moves import TABLE_CANDIDATES_M
from scenarios.offline.scan import (
    ObjectBox,
    PlannedPass,
    ScanData,
    choose_table_position,
    crop_to_object,
    execute_scan,
)
from scenarios.offline.settings import Scan

Progress = Callable[[str], None]
#: Least allowed difference at a target [m]: below it, the two matches agree within what
#: the laser alone resolves.
FLOOR_M = 3.0e-4
#: Points of the strip the check's match uses at most.
STRIP_POINTS = 3000


@dataclass(frozen=True)
class TargetCheck:
    """One target placed by the registered pose and by the strip's own match: how far apart
    [m], and how far the two matches' predicted errors allow [m]."""

    name: str
    moved_m: float
    allowed_m: float

    @property
    def agrees(self) -> bool:
        return self.moved_m <= self.allowed_m


@dataclass(frozen=True)
class Verification:
    """The strip re-scanned (its pass' name), its points on the object, each target's
    check; the registration agrees if every target does."""

    strip: str
    points: int
    checks: tuple[TargetCheck, ...]

    @property
    def agrees(self) -> bool:
        return self.points > 0 and all(c.agrees for c in self.checks)

    def summary(self) -> str:
        worst = max(self.checks, key=lambda c: c.moved_m / c.allowed_m)
        return (
            f"{self.strip} again ({self.points} points): the targets moved up to "
            f"{worst.moved_m * 1e3:.2f} mm ({worst.name}; allowed {worst.allowed_m * 1e3:.2f})"
        )


def target_spread(
    points_table: np.ndarray,
    shape: MeshModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
) -> float:
    """The worst target's predicted error [m] (per unit point noise) from points (N, 3) of
    the object at its pose T_table_object alone: the point-to-plane information of the
    points, propagated to each target (K, 3, model frame)."""
    p = transform_points(invert(T_table_object), points_table)
    closest = shape.closest(p)
    if closest.normals is None or len(p) < 6:
        return float("inf")
    n = closest.normals
    J = np.hstack([n, np.cross(closest.points, n)])
    info = J.T @ J
    if np.linalg.cond(info) > 1e12:
        return float("inf")
    cov = np.linalg.inv(info)
    worst = 0.0
    for t in np.asarray(targets_model):
        A = np.hstack([np.eye(3), -_skew(t)])  # target motion of (translation, rotation)
        worst = max(worst, float(np.trace(A @ cov @ A.T)))
    return float(np.sqrt(worst))


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def choose_strip(
    scan: ScanData,
    keep: np.ndarray,
    shape: MeshModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
) -> int:
    """The pass of `scan` (its object points `keep` (N,)) whose points alone locate the
    targets best."""
    point_pass = scan.line_pass[scan.line_index][keep]
    points = scan.points_table[keep]
    spreads = {
        int(k): target_spread(points[point_pass == k], shape, T_table_object, targets_model)
        for k in np.unique(point_pass)
    }
    return min(spreads, key=lambda k: spreads[k])


@dataclass(frozen=True, eq=False)
class RegisteredTargets:
    """The registration to verify: the object's pose T_table_object (4, 4) [m] in the nominal
    table frame, the operation targets (name, point (3,) in the model frame) and the
    registration's predicted TRE at each (K,) [m]."""

    T_table_object: np.ndarray
    targets: tuple[tuple[str, np.ndarray], ...]
    predicted_tre_m: np.ndarray


@dataclass(frozen=True, eq=False)
class ScanRecord:
    """The scan the registration was made on: what the laser measured, which of its points
    (N,) were kept as the object's, and the passes it ran."""

    scan: ScanData
    keep: np.ndarray
    plan: tuple[PlannedPass, ...]


def verify_registration(
    controller: Controller,
    virtual: ObjectModel,
    registered: RegisteredTargets,
    scanned: ScanRecord,
    box: ObjectBox,
    section: Scan,
    table_position_m: float,
    model: CellModel,
    pass_sigma_m: float,
    say: Progress,
) -> Verification:
    """Scan a strip of the object again and match it on its own (see the module's
    docstring), at `table_position_m` [m] (the program's) if the arm follows it there; the
    pass of the scan `scanned` whose points alone locate the targets best, scanned again
    with the cell's `model`, its points matched from the `registered` pose, each target
    compared; `pass_sigma_m` [m] is the arm's accuracy (a pass's rigid offset, per axis)."""
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    targets_model = np.array([p for _, p in registered.targets])
    T_table_object = registered.T_table_object
    k = choose_strip(scanned.scan, scanned.keep, shape, T_table_object, targets_model)
    planned = scanned.plan[k]
    points = _rescan(controller, planned, box, section, table_position_m, model, say)
    if len(points) < 100:
        return Verification(planned.name, len(points), ())
    located = localize(
        points,
        shape,
        STRIP_POINTS,
        Acceptance(),
        0,
        mode="refine",
        T_table_object_prior=T_table_object,
        passes=ScanPasses(np.zeros(len(points), dtype=int), pass_sigma_m),
    )
    tre_strip = located.result.predicted_tre(targets_model).tre
    before = transform_points(T_table_object, targets_model)
    after = transform_points(located.T_table_object, targets_model)
    moved = np.linalg.norm(after - before, axis=1)
    allowed = np.maximum(FLOOR_M, 3.0 * np.hypot(registered.predicted_tre_m, tre_strip))
    checks = tuple(
        TargetCheck(name, float(m), float(a))
        for (name, _), m, a in zip(registered.targets, moved, allowed, strict=True)
    )
    return Verification(planned.name, len(points), checks)


def _rescan(
    controller: Controller,
    planned: PlannedPass,
    box: ObjectBox,
    section: Scan,
    table_position_m: float,
    model: CellModel,
    say: Progress,
) -> np.ndarray:
    """The pass `planned` scanned again at `table_position_m` [m] if the arm follows it
    there (else at the first table position it does), the table back where it was after:
    the points (M, 3) [m] in the table frame within the object's box."""
    order = (table_position_m, *(s for s in TABLE_CANDIDATES_M if s != table_position_m))
    s, q = choose_table_position(
        controller.kinematics.for_tool("laser"),
        LASER.T_tool_tcp,
        planned.T_table_start,
        planned.T_table_end,
        controller.read_joints(),
        planned.name,
        model.T_base_table,
        order,
    )
    strip = PlannedPass(
        planned.name, planned.T_table_start, planned.T_table_end, s, q, model.T_base_table(s)
    )
    table_before = controller.table_position()
    again = execute_scan(controller, (strip,), section, say, model)
    # The table goes back where the scan left it: the tool change that follows is planned
    # with it there (at the program's position the object can stand in its way).
    if abs(controller.table_position() - table_before) > 1e-6:
        controller.move_table(table_before)
    return again.points_table[crop_to_object(again.points_table, box, section.crop_margin_m)]
