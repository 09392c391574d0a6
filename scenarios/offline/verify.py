"""Verification after correction: the registration checked on the object before any target
is touched, as a neuronavigation system verifies its registration on landmarks.

After the match, the laser re-scans small patches of the object at verification points
away from the targets, at the table position the program will run at. Each patch is
compared with the registered model (the median signed distance of its points from the
surface) and with how the scan the match was made on lay on the model at the same place:
the model's own error there and the match's error cancel in the difference, so what is left
is how far the object moved since the scan, plus the two scans' arm errors. A difference
beyond three standard deviations of those errors means the object moved, or the scan the
match came from was wrong (a table that did not go where its readout says, a tool seated
off). Two patches whose normals point 90 degrees apart see a move in any direction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller
from models import ObjectModel
from models.robot import LASER
from registration import MeshModel, invert, transform_points
from scenarios.jobs.config import Scan
from scenarios.offline.cell_model import CellModel
from scenarios.offline.moves import TABLE_CANDIDATES_M, UnreachablePlanError
from scenarios.offline.scan import PlannedPass, choose_table_position, execute_scan

Progress = Callable[[str], None]
#: Half the length of a verification patch's sweep [m].
PATCH_HALF_M = 0.02
#: A verification point lies at least this far from every target [m].
AWAY_FROM_TARGETS_M = 0.04
#: Patch points farther than this from the model are not on it [m].
ON_MODEL_M = 0.01
#: Least allowed difference [m]: below it, the comparison is within the laser's own noise.
FLOOR_M = 3.0e-4
#: A patch (and the scan at its place) needs this many points on the model.
MIN_POINTS = 20


@dataclass(frozen=True)
class VerifyPoint:
    """A verification point on the registered model: where (3,) and its outward normal (3,)
    in the table frame, and in the model frame (3,)."""

    name: str
    p_table: np.ndarray
    n_table: np.ndarray
    p_model: np.ndarray


@dataclass(frozen=True)
class PatchCheck:
    """One patch against the registered model: its points on the model, their median signed
    distance from it [m] (outside > 0), the same of the scan the match was made on there
    (`scanned_m`), the difference allowed [m]."""

    name: str
    points: int
    offset_m: float
    scanned_m: float
    allowed_m: float

    @property
    def moved_m(self) -> float:
        """How far the surface there moved along its normal since the scan [m]."""
        return self.offset_m - self.scanned_m

    @property
    def agrees(self) -> bool:
        return self.points >= MIN_POINTS and abs(self.moved_m) <= self.allowed_m


@dataclass(frozen=True)
class Verification:
    """The patches' checks; the registration agrees if every patch does."""

    checks: tuple[PatchCheck, ...]

    @property
    def agrees(self) -> bool:
        return all(c.agrees for c in self.checks)

    def summary(self) -> str:
        return ", ".join(
            f"{c.name}: moved {c.moved_m * 1e3:+.2f} mm (allowed {c.allowed_m * 1e3:.2f}, "
            f"{c.points} points)"
            for c in self.checks
        )


def verification_points(
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
    count: int = 2,
    ranked: int = 12,
) -> tuple[tuple[VerifyPoint, ...], ...]:
    """For each of `count` verification places, up to `ranked` candidate points of the
    model's surface, best first: facing up and sideways (normal 30-60 degrees from the
    vertical, so that a patch sees the object's shape across it), at least
    AWAY_FROM_TARGETS_M from every target, high on the object, their headings as far apart
    as can be (90 degrees for two): together they see a move of the object in any
    direction. The candidates stand in for one another where the arm cannot reach."""
    mesh = virtual.mesh.to_trimesh()
    v = np.asarray(mesh.vertices, dtype=float)
    n = np.asarray(mesh.vertex_normals, dtype=float)
    R, t = T_table_object[:3, :3], T_table_object[:3, 3]
    p_table, n_table = v @ R.T + t, n @ R.T
    ok = (n_table[:, 2] >= np.cos(np.deg2rad(60))) & (n_table[:, 2] <= np.cos(np.deg2rad(30)))
    if len(targets_model):
        d = np.linalg.norm(v[:, None, :] - np.asarray(targets_model)[None], axis=2)
        ok &= d.min(axis=1) >= AWAY_FROM_TARGETS_M
    idx = np.nonzero(ok)[0]
    if len(idx) == 0:
        return ()
    heading = np.arctan2(n_table[idx, 1], n_table[idx, 0])
    high = p_table[idx, 2]
    height = (high - high.min()) / max(float(np.ptp(high)), 1e-9)
    step = np.pi / 2 if count == 2 else 2 * np.pi / count
    places = []
    for k in range(count):
        # Towards the robot first (heading pi: the arm's side of the object), then turned.
        gap = np.abs(np.angle(np.exp(1j * (heading - np.pi - k * step))))
        order = np.argsort(gap - 0.5 * height)[:ranked]
        places.append(
            tuple(
                VerifyPoint(f"check {k + 1}", p_table[idx[i]], n_table[idx[i]], v[idx[i]])
                for i in order
            )
        )
    return tuple(places)


def _look_at(n: np.ndarray) -> np.ndarray:
    """(3, 3) laser orientation looking along -n, its fan across, its sweep along the
    horizontal tangent."""
    z = -n / np.linalg.norm(n)
    sweep = np.cross(z, [0.0, 0.0, 1.0])
    sweep /= np.linalg.norm(sweep)
    x = np.cross(sweep, z)
    return np.column_stack([x, sweep, z])


def plan_patches(
    controller: Controller,
    places: tuple[tuple[VerifyPoint, ...], ...],
    standoff_m: float,
    table_position_m: float,
    model: CellModel,
) -> tuple[tuple[PlannedPass, VerifyPoint], ...]:
    """A short pass over a verification point of each place (its first candidate the arm
    reaches), at the program's table position when the arm reaches it there."""
    kin = controller.kinematics.for_tool("laser")
    q = controller.read_joints()
    order = (table_position_m, *(s for s in TABLE_CANDIDATES_M if s != table_position_m))
    passes = []
    for candidates in places:
        for point in candidates:
            R = _look_at(point.n_table)
            p_mid = point.p_table + standoff_m * point.n_table
            T_start, T_end = np.eye(4), np.eye(4)
            T_start[:3, :3] = T_end[:3, :3] = R
            T_start[:3, 3] = p_mid - PATCH_HALF_M * R[:, 1]
            T_end[:3, 3] = p_mid + PATCH_HALF_M * R[:, 1]
            try:
                s, q = choose_table_position(
                    kin, LASER.T_tool_tcp, T_start, T_end, q, point.name, model.T_base_table,
                    order,
                )  # fmt: skip
            except UnreachablePlanError:
                continue
            passes.append(
                (PlannedPass(point.name, T_start, T_end, s, q, model.T_base_table(s)), point)
            )
            break
    if len(passes) < len(places):
        raise UnreachablePlanError(
            f"verification: the arm reaches {len(passes)} of {len(places)} patches"
        )
    return tuple(passes)


def _offset(
    shape: MeshModel, T_object_table: np.ndarray, points_table: np.ndarray
) -> tuple[float, int]:
    """Median signed distance [m] of points (N, 3, table frame) from the model at the
    registered pose (outside > 0), over those within ON_MODEL_M of it, and their count."""
    if len(points_table) == 0:
        return float("nan"), 0
    p_model = transform_points(T_object_table, points_table)
    closest = shape.closest(p_model)
    on = closest.distances <= ON_MODEL_M
    normals = closest.normals if closest.normals is not None else np.zeros_like(p_model)
    signed = np.einsum("ij,ij->i", p_model - closest.points, normals)[on]
    return (float(np.median(signed)) if len(signed) else float("nan")), len(signed)


def verify_registration(
    controller: Controller,
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    scanned_table: np.ndarray,
    targets_model: np.ndarray,
    section: Scan,
    table_position_m: float,
    model: CellModel,
    pass_sigma_m: float,
    say: Progress,
    count: int = 2,
) -> Verification:
    """Re-scan a patch at each of `count` verification points (see the module) and compare
    it with the registered model at `T_table_object` (4, 4), against how the scan the match
    was made on (`scanned_table`, (N, 3) table frame) lay there: the model's own error and
    the match's cancel, what is left is the object's move and the two scans' arm errors
    (`pass_sigma_m` per axis [m], the data sheet's): three sigma of their difference is
    allowed."""
    places = verification_points(virtual, T_table_object, targets_model, count)
    planned = plan_patches(controller, places, section.standoff_m, table_position_m, model)
    points = [point for _, point in planned]
    scan = execute_scan(controller, tuple(p for p, _ in planned), section, say, model)
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    T_object_table = invert(T_table_object)
    allowed = max(FLOOR_M, 3.0 * np.sqrt(2.0) * pass_sigma_m)
    checks = []
    for k, point in enumerate(points):
        mine = scan.line_pass[scan.line_index] == k
        patch = scan.points_table[mine]
        near = np.linalg.norm(patch - point.p_table, axis=1) <= PATCH_HALF_M
        before = np.linalg.norm(scanned_table - point.p_table, axis=1) <= PATCH_HALF_M
        offset, n = _offset(shape, T_object_table, patch[near])
        scanned, n0 = _offset(shape, T_object_table, scanned_table[before])
        if n0 < MIN_POINTS:  # the scan did not see this place: the model is the reference
            scanned = 0.0
        checks.append(PatchCheck(point.name, n, offset, scanned, allowed))
    return Verification(tuple(checks))
