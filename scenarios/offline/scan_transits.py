"""The moves between a scan's passes, checked in the virtual cell as the scan runs them
(scenarios.offline.scan_plan): from home to the first pass, and from each pass's end, the
laser risen, to the next pass's start; one that would bring the arm or the laser against
the object or the cell goes through home, and one that clears neither way is refused
(`TransitError`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from cell import Kinematics, nominal_T_base_table
from cell.virtual import VirtualCell
from models.robot import LASER
from scenarios.offline.premotion import joint_move_samples
from scenarios.offline.premotion_verdict import PremotionLimits
from scenarios.offline.scan_candidates import Candidate, ScanPlanError
from scenarios.offline.scan_passes import PlannedPass, risen


class TransitError(ScanPlanError):
    """No clear way to the start of the plan's pass `index`, directly or through home."""

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.index = index
        #: The candidates the routed plan was made of, in its order (None: not a chosen plan).
        self.plan: tuple[Candidate, ...] | None = None


#: How finely a transit is checked: the pre-motion check's steps (TCP travel, joint angle).
TRANSIT_LIMITS = PremotionLimits()


def retreat_q(
    kin: Kinematics, planned: PlannedPass, T_base_table: Callable[[float], np.ndarray]
) -> np.ndarray | None:
    """The joints (6,) at the end of a pass after the laser's rise (as the scan runs it:
    RETREAT_M up, or half of it), or None if the arm does not follow."""
    T_base = T_base_table(planned.table_position_m)
    end = kin.ik(T_base @ planned.T_table_last, planned.q_start, LASER.T_tool_tcp, extra_seeds=4)
    if not end.success:
        return None
    for T_up in risen(T_base @ planned.T_table_last):
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
    rose = retreat_q(kin, planned, T_base_table)
    return planned.q_start if rose is None else rose
