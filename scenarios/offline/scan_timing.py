"""The scan's cell time as the planner predicts it: a joint move and its settling (the
controller's quintic profile, the slowest joint at its speed limit at the peak), a pass's
sweep and the laser's rise after it, and a whole scan's motions from home
(scenarios.offline.scan_plan).
"""

from __future__ import annotations

import numpy as np

from cell.controller import SETTLE_S
from cell.trajectory import QUINTIC_PEAK
from models.robot import TABLE_SPEED
from scenarios.offline.scan_passes import RETREAT_M, RETREAT_SPEED_M_S, PlannedPass
from scenarios.offline.settings import Scan


def joint_move_s(q_from: np.ndarray, q_to: np.ndarray, joint_speed: np.ndarray) -> float:
    """Cell time [s] of a joint move and its settling: the controller's quintic profile,
    the slowest joint at its speed limit at the peak."""
    dq = np.abs(np.asarray(q_to) - np.asarray(q_from))
    return float(np.max(QUINTIC_PEAK * dq / joint_speed)) + SETTLE_S


def _line_s(length_m: float, speed_m_s: float, settle_s: float = SETTLE_S) -> float:
    """Cell time [s] of a straight move of `length_m` [m] at `speed_m_s` and its settling."""
    return QUINTIC_PEAK * length_m / speed_m_s + settle_s


def pass_seconds(planned: PlannedPass, section: Scan) -> float:
    """Cell time [s] of a pass itself: its sweep (a raster's lines and the steps between
    them, not settled but the last) and the laser's rise after it."""
    total, end = 0.0, None
    for start, stop in planned.lines():
        if end is not None:
            total += _line_s(float(np.linalg.norm(start[:3, 3] - end)), section.speed_m_s, 0.0)
        total += _line_s(float(np.linalg.norm(stop[:3, 3] - start[:3, 3])), section.speed_m_s, 0.0)
        end = stop[:3, 3]
    return total + SETTLE_S + _line_s(RETREAT_M, RETREAT_SPEED_M_S)


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
            total += joint_move_s(q, q_next, joint_speed)
            q = q_next
        total += pass_seconds(p, section)
    return total
