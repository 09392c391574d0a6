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
from dataclasses import dataclass
from typing import Literal

import numpy as np

from cell import Kinematics
from cell.trajectory import straight_path
from cell.virtual import Contact, VirtualCell
from scenarios.offline.premotion_verdict import (
    CheckedMove,
    Kind,
    PremotionCheck,
    PremotionError,
    PremotionLimits,
    Problem,
)
from scenarios.program.program_types import OfflineProgram

#: A line's IK solution may not move a joint more than this between samples [rad] (the
#: controller's own test for a configuration flip).
FLIP_RAD = 0.5
#: A joint move's end must put the TCP this close to the program's approach [m], [rad].
APPROACH_TOL_M = 1e-4
APPROACH_TOL_RAD = 1e-3


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
        program: the corrected program (scenarios.offline.program_plan.plan_program).
        kinematics: the arm's kinematics the program was solved with (the controller's
            `kinematics`, nominal or calibrated); its joint ranges for the program's tool.
        cell: the virtual cell, the object where the program believes it is
            (scenarios.offline.job_cell.job_virtual_cell); posed here (joints, table, tool).
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
