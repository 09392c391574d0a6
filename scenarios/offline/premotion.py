"""The pre-motion check: the corrected program run in the virtual cell before it moves the arm.

An offline-programming tool checks a program in its model of the cell before sending it to the
controller; this is that check for an `OfflineProgram`. It follows the moves
`execute_program` makes, from `q_start` with the program's tool in hand and the table at the
program's position: for each operation the joint move to its approach (a straight line in
joint space, as cell.trajectory interpolates it), the straight TCP line to the touch and the
line back (solved point by point with the program's kinematics, seeded from the previous
point, as the controller solves them). Every move is sampled finely (`PremotionLimits`:
every `step_m` of TCP travel and `step_rad` of joint motion) and each sample is checked for:

- reach: the line's IK converges without a configuration flip (a joint jumping more than
  0.5 rad between samples, the controller's own refusal), and a joint move's end puts the
  TCP where the program says its approach is;
- joint_limit: every joint within its range for the tool in hand, `joint_margin_rad` inside;
- singularity (linear moves, where the controller inverts the kinematics): the smallest
  singular value of the flange's 6 x 6 geometric Jacobian ([m/rad] rows for the linear
  velocity, [rad/rad] for the angular) stays above `min_singular_value`. It vanishes at every
  singularity of the arm (wrist straight, wrist centre on the first axis, arm stretched); on
  the built-in arm it is about 0.44 sin(q5) near the wrist's, so the default 0.04 keeps the
  wrist 5 degrees from straight;
- collision: in the virtual cell (cell.virtual: the nominal cell with the object at the
  pose the program was corrected with; near the object, its own surface rather than its
  convex pieces, which stand proud of a rough one), no arm link or the tool in hand comes
  within `clearance_m` of anything else, except the tool in hand and the touched object on the
  lines into and out of the touch, which are meant to come close and only may not
  penetrate (`touch_clearance_m`).

The result lists each problem once per move and kind (and pair of bodies), with where along
the move it starts and ends, and says in one line why the program is refused.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from cell import FixedMesh, FixedPrimitive, Kinematics
from cell.robots import Robot
from cell.trajectory import straight_path
from cell.virtual import EXACT_BAND_M, Contact, VirtualCell
from models.model import ObjectModel
from scenarios.errors import ScenarioError
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.program import OfflineProgram
from scenarios.offline.settings import FixtureTolerance

Kind = Literal["reach", "joint_limit", "singularity", "collision"]
KINDS: tuple[str, ...] = ("reach", "joint_limit", "singularity", "collision")
#: A line's IK solution may not move a joint more than this between samples [rad] (the
#: controller's own test for a configuration flip).
FLIP_RAD = 0.5
#: A joint move's end must put the TCP this close to the program's approach [m], [rad].
APPROACH_TOL_M = 1e-4
APPROACH_TOL_RAD = 1e-3
_VERBS = {
    "collision": "collides",
    "reach": "leaves the arm's reach",
    "joint_limit": "runs into joint limits",
    "singularity": "passes near a singularity",
}


class PremotionError(ScenarioError, ValueError):
    """A pre-motion check asked with bad settings or a bad start."""


@dataclass(frozen=True)
class PremotionLimits:
    """How finely and how strictly the check looks (see the module's docstring).

    `step_m` [m] of TCP travel and `step_rad` [rad] of the largest joint's motion between
    samples; `clearance_m` [m] the least distance between the moving side and anything else;
    `touch_clearance_m` [m] that between the tool in hand and the touched object on the lines
    into and out of a touch (0: they may not penetrate); `joint_margin_rad` [rad] inside the
    joint limits; `min_singular_value` of the flange's Jacobian; `watch_m` [m]: distances up
    to this are measured, so that the closest approach of each move is reported.
    """

    step_m: float = 0.005
    step_rad: float = 0.02
    clearance_m: float = 0.002
    touch_clearance_m: float = 0.0
    joint_margin_rad: float = float(np.deg2rad(1.0))
    min_singular_value: float = 0.04
    watch_m: float = 0.1

    def __post_init__(self) -> None:
        for name in ("step_m", "step_rad"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise PremotionError(f"PremotionLimits.{name} must be > 0, got {value!r}")
        for name in (
            "clearance_m",
            "touch_clearance_m",
            "joint_margin_rad",
            "min_singular_value",
            "watch_m",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise PremotionError(f"PremotionLimits.{name} must be >= 0, got {value!r}")
        if max(self.clearance_m, self.touch_clearance_m) > 0.5:
            raise PremotionError(
                "PremotionLimits: clearances beyond 0.5 m are not a clearance, got "
                f"{self.clearance_m!r}, {self.touch_clearance_m!r}"
            )


@dataclass(frozen=True)
class Problem:
    """Why a move may not run: `move` its name ("kocher_left: approach -> touch"), `kind` one
    of KINDS, `detail` what and where ("tool_screwer touches object (2.7 mm deep) from 40 % to
    100 %")."""

    move: str
    kind: Kind
    detail: str

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise PremotionError(f"problem kind {self.kind!r} is not one of {KINDS}")

    def __str__(self) -> str:
        return f"{self.move}: {self.detail}"


@dataclass(frozen=True)
class CheckedMove:
    """A move the check followed: its name, `joint` or `linear`, the poses sampled on it
    (its start excluded: the previous move's end), its closest approach (the smallest
    distance checked against the clearance, within `PremotionLimits.watch_m`; None: nothing
    that near), and on a line into or out of a touch the smallest gap between the tool in
    hand and the touched object [m] (None elsewhere, or nothing that near)."""

    name: str
    kind: Literal["joint", "linear"]
    samples: int
    closest: Contact | None
    touch_gap_m: float | None = None


@dataclass(frozen=True)
class PremotionCheck:
    """The check's verdict: `ok` when no move has a problem; the `problems` in the order of
    the moves; the `moves` followed; the `limits` applied; the wall time [s]."""

    ok: bool
    problems: tuple[Problem, ...]
    moves: tuple[CheckedMove, ...]
    limits: PremotionLimits
    seconds: float = field(default=0.0, compare=False)

    @property
    def samples(self) -> int:
        """The poses checked, over all moves."""
        return sum(m.samples for m in self.moves)

    @property
    def closest(self) -> tuple[str, Contact] | None:
        """The program's closest approach: the move and the contact, or None."""
        near = [(m.name, c) for m in self.moves if (c := m.closest) is not None]
        return min(near, key=lambda item: item[1].distance_m) if near else None

    def kinds(self) -> tuple[str, ...]:
        """The kinds of the problems found, in KINDS' order."""
        return tuple(k for k in KINDS if any(p.kind == k for p in self.problems))

    @property
    def summary(self) -> str:
        """One line: why the program is refused, or what the check found."""
        if self.ok:
            closest = self.closest
            near = (
                f"; closest: {closest[1].body} {closest[1].distance_m * 1e3:.1f} mm from "
                f"{closest[1].other} ({closest[0]})"
                if closest is not None
                else ""
            )
            return (
                f"the corrected program passes the pre-motion check: {len(self.moves)} moves, "
                f"{self.samples} poses, clearance {self.limits.clearance_m * 1e3:g} mm{near}"
            )
        verbs = " and ".join(_VERBS[k] for k in self.kinds())
        shown = "; ".join(str(p) for p in self.problems[:6])
        more = len(self.problems) - 6
        return f"the corrected program {verbs}: {shown}" + (
            f" (and {more} more)" if more > 0 else ""
        )


# -- what the pipeline hands the check ----------------------------------------------------------
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


# -- the check ----------------------------------------------------------------------------------
def _count(steps: float) -> int:
    """Samples for a move `steps` steps long (at least one; a whole number of steps is not
    rounded up by its last bit)."""
    return max(1, math.ceil(steps - 1e-9))


def joint_move_samples(
    kin: Kinematics,
    T_flange_tcp: np.ndarray,
    q0: np.ndarray,
    q1: np.ndarray,
    step_m: float,
    step_rad: float,
) -> np.ndarray:
    """Fractions (n,) in (0, 1] of the joint move q0 -> q1 (a line in joint space) at which
    to check it: the largest joint at most `step_rad` [rad] and the TCP at most `step_m` [m]
    of travel apart."""
    dq = np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float)
    n = _count(float(np.max(np.abs(dq))) / step_rad)
    for _ in range(3):
        s = np.arange(0, n + 1) / n
        p = np.array([(kin.fk(q0 + sk * dq) @ T_flange_tcp)[:3, 3] for sk in s])
        hop = float(np.max(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        if hop <= step_m:
            break
        n = math.ceil(n * hop / step_m * 1.05)
    return np.arange(1, n + 1) / n


@dataclass
class _Finding:
    first: float
    last: float
    worst: float
    text: str


class _Move:
    """What one move found, by kind and key, merged over its samples."""

    def __init__(self, name: str, kind: Literal["joint", "linear"]) -> None:
        self.name = name
        self.kind: Literal["joint", "linear"] = kind
        self.findings: dict[tuple[Kind, object], _Finding] = {}
        self.closest: Contact | None = None
        self.touch_gap_m: float | None = None
        self.samples = 0

    def add(self, kind: Kind, key: object, at: float, worst: float, text: str) -> None:
        """A problem at fraction `at` of the move; `worst` ranks samples (larger: worse),
        `text` describes the worst one."""
        found = self.findings.get((kind, key))
        if found is None:
            self.findings[(kind, key)] = _Finding(at, at, worst, text)
            return
        found.last = at
        if worst > found.worst:
            found.worst, found.text = worst, text

    def problems(self) -> list[Problem]:
        out = []
        for (kind, _key), f in self.findings.items():
            first, last = round(100 * f.first), round(100 * f.last)
            where = f"at {first} %" if first == last else f"from {first} % to {last} %"
            out.append(Problem(self.name, kind, f"{f.text} {where}"))
        return out


class _Checker:
    def __init__(
        self,
        program: OfflineProgram,
        kinematics: Kinematics,
        cell: VirtualCell,
        T_flange_tcp: np.ndarray,
        limits: PremotionLimits,
        object_name: str,
    ) -> None:
        self.kin = kinematics.for_tool(program.tool)
        self.cell = cell
        self.T_tcp = np.asarray(T_flange_tcp, dtype=float)
        self.limits = limits
        self.object_name = object_name
        self.tool_body = f"tool_{program.tool}"
        self.names = [str(n) for n in list(self.kin.model.names)[1:]]  # one per joint
        self.moves: list[_Move] = []
        self.margin = max(limits.watch_m, limits.clearance_m, limits.touch_clearance_m)

    # per sample
    def _joints(self, move: _Move, q: np.ndarray, at: float) -> None:
        margin = self.limits.joint_margin_rad
        lower, upper = self.kin.lower + margin, self.kin.upper - margin
        for j in np.flatnonzero((q < lower) | (q > upper)):
            low = q[j] < lower[j]
            limit = self.kin.lower[j] if low else self.kin.upper[j]
            beyond = (limit - q[j]) if low else (q[j] - limit)
            where = "beyond" if beyond > 0 else f"within {np.rad2deg(margin):g} deg of"
            move.add(
                "joint_limit",
                (int(j), low),
                at,
                float(beyond),
                f"{self.names[j]} at {np.rad2deg(q[j]):.1f} deg, {where} its limit "
                f"{np.rad2deg(limit):.1f} deg,",
            )

    def _singularity(self, move: _Move, q: np.ndarray, at: float) -> None:
        sigma = float(np.linalg.svd(self.kin.jacobian(q), compute_uv=False)[-1])
        if sigma < self.limits.min_singular_value:
            move.add(
                "singularity",
                None,
                at,
                -sigma,
                f"the arm is near a singularity (smallest singular value of the Jacobian "
                f"{sigma:.3f} < {self.limits.min_singular_value:g})",
            )

    def _collisions(self, move: _Move, q: np.ndarray, at: float, touching: bool) -> None:
        self.cell.set_joints(q)
        limits = self.limits
        for c in self.cell.contacts(self.margin):
            allowed = touching and c.body == self.tool_body and c.other == self.object_name
            clearance = limits.touch_clearance_m if allowed else limits.clearance_m
            if allowed:
                gap = move.touch_gap_m
                move.touch_gap_m = c.distance_m if gap is None else min(gap, c.distance_m)
            elif move.closest is None or c.distance_m < move.closest.distance_m:
                move.closest = c
            if c.distance_m >= clearance:
                continue
            if c.distance_m < 0.0:
                text = f"{c.body} touches {c.other} ({-c.distance_m * 1e3:.1f} mm deep)"
            else:
                text = (
                    f"{c.body} comes within {c.distance_m * 1e3:.1f} mm of {c.other} "
                    f"(clearance {clearance * 1e3:g} mm)"
                )
            move.add("collision", (c.body, c.other), at, -c.distance_m, text)

    # per move
    def joint_move(self, name: str, q0: np.ndarray, q1: np.ndarray, T_target: np.ndarray) -> None:
        """The joint move q0 -> q1 (a line in joint space), then whether q1 puts the TCP at
        `T_target`."""
        move = _Move(name, "joint")
        self.moves.append(move)
        dq = q1 - q0
        # As finely as the TCP moves: its travel between samples at most step_m.
        for at in joint_move_samples(
            self.kin, self.T_tcp, q0, q1, self.limits.step_m, self.limits.step_rad
        ):
            at = float(at)
            q = q0 + at * dq
            move.samples += 1
            self._joints(move, q, at)
            self._collisions(move, q, at, touching=False)
        T_end = self.kin.fk(q1) @ self.T_tcp
        dp = float(np.linalg.norm(T_end[:3, 3] - T_target[:3, 3]))
        R = T_end[:3, :3].T @ T_target[:3, :3]
        dr = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
        if dp > APPROACH_TOL_M or dr > APPROACH_TOL_RAD:
            move.add(
                "reach",
                "target",
                1.0,
                dp,
                f"its joints put the TCP {dp * 1e3:.1f} mm and {np.rad2deg(dr):.2f} deg from "
                "the program's pose",
            )

    def linear_move(
        self, name: str, q0: np.ndarray, T_target: np.ndarray, q_planned: np.ndarray
    ) -> np.ndarray:
        """The straight TCP line from where q0 puts it to `T_target`; returns the joints at its
        end (`q_planned` where the line cannot be followed)."""
        move = _Move(name, "linear")
        self.moves.append(move)
        T0 = self.kin.fk(q0) @ self.T_tcp
        dist = float(np.linalg.norm(T_target[:3, 3] - T0[:3, 3]))
        R = T0[:3, :3].T @ T_target[:3, :3]
        angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
        n = _count(max(dist / self.limits.step_m, angle / self.limits.step_rad))
        s = np.arange(1, n + 1) / n
        q = q0
        for k, T in enumerate(straight_path(T0, T_target, s)):
            at = float(s[k])
            r = self.kin.ik(T, q, self.T_tcp, extra_seeds=0)
            jump = float(np.max(np.abs(r.q - q)))
            if not r.success or jump > FLIP_RAD:
                if r.success:
                    j = int(np.argmax(np.abs(r.q - q)))
                    text = f"the arm flips configuration ({self.names[j]} jumps {jump:.2f} rad)"
                else:
                    text = (
                        f"no IK solution for the TCP (residual {r.position_error_m * 1e3:.1f} "
                        f"mm, {np.rad2deg(r.rotation_error_rad):.2f} deg)"
                    )
                move.add("reach", None, at, 1.0, text)
                return np.asarray(q_planned, dtype=float)
            q = r.q
            move.samples += 1
            self._joints(move, q, at)
            self._singularity(move, q, at)
            self._collisions(move, q, at, touching=True)
        return q

    def result(self, seconds: float) -> PremotionCheck:
        problems = tuple(p for m in self.moves for p in m.problems())
        moves = tuple(
            CheckedMove(m.name, m.kind, m.samples, m.closest, m.touch_gap_m) for m in self.moves
        )
        return PremotionCheck(not problems, problems, moves, self.limits, seconds)


def check_program(
    program: OfflineProgram,
    kinematics: Kinematics,
    cell: VirtualCell,
    q_start: np.ndarray,
    T_flange_tcp: np.ndarray,
    limits: PremotionLimits | None = None,
    object_name: str = "object",
) -> PremotionCheck:
    """Check `program` in the virtual `cell` before it moves (see the module's docstring).

    Args:
        program: the corrected program (scenarios.offline.program.plan_program).
        kinematics: the arm's kinematics the program was solved with (the controller's
            `kinematics`, nominal or calibrated); its joint ranges for the program's tool.
        cell: the virtual cell, the object where the program believes it is
            (`job_virtual_cell`); posed here (joints, table, tool).
        q_start: (6,) [rad] the joints the first joint move starts from: home after a tool
            change (`change_tool_safely` ends there), else where the arm stands.
        T_flange_tcp: (4, 4) the tool's TCP in the flange frame (its tooldata).
        limits: sampling and margins (default `PremotionLimits()`).
        object_name: the touched object's name in `cell` (the touch allowance's other side).
    """
    t0 = time.perf_counter()
    limits = limits or PremotionLimits()
    q0 = np.asarray(q_start, dtype=float).reshape(-1)
    if q0.shape != (6,) or not np.all(np.isfinite(q0)):
        raise PremotionError(f"q_start must be 6 finite joint angles [rad], got {q_start!r}")
    T_tcp = np.asarray(T_flange_tcp, dtype=float)
    if T_tcp.shape != (4, 4) or not np.all(np.isfinite(T_tcp)):
        raise PremotionError(f"T_flange_tcp must be a finite (4, 4) transform, got {T_tcp!r}")
    cell.set_tool(program.tool)
    cell.set_table(program.table_position_m)
    checker = _Checker(program, kinematics, cell, T_tcp, limits, object_name)
    q = q0
    for planned in program.operations:
        name = planned.operation.name
        q_app = np.asarray(planned.q_approach, dtype=float)
        checker.joint_move(f"{name}: approach", q, q_app, planned.T_base_approach)
        q = checker.linear_move(
            f"{name}: approach -> touch", q_app, planned.T_base_touch, planned.q_touch
        )
        q = checker.linear_move(
            f"{name}: touch -> approach", q, planned.T_base_approach, planned.q_approach
        )
    return checker.result(time.perf_counter() - t0)


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
        return not any(c.other == name for c in cell.contacts(margin_m))

    return clear
