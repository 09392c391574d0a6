"""A RAPID move's joints on the controller's nominal arm, for the planner
(scenarios.rapid.planner): MoveJ solves the target in the robtarget's confdata
(scenarios.rapid.confdata), MoveL follows the straight line from the previous point and must
end in the robtarget's confdata (ConfL\\On); and the fraction of the joints' speed limits at
which a joint move gives the programmed TCP speed.
"""

from __future__ import annotations

import math

import numpy as np

from cell import Kinematics
from cell.trajectory import straight_path
from scenarios.rapid.confdata import Conf, honours, solve_in_configuration
from scenarios.rapid.flow import Step, program_error
from scenarios.rapid.move_data import PlanState
from scenarios.rapid.rapid_text import configuration
from scenarios.rapid.task import ModuleScope

#: Largest joint step between two samples of a straight move [rad] (the controller's).
MAX_JOINT_STEP_RAD = 0.5
_LINE_STEP_M = 2e-3
_LINE_STEP_RAD = float(np.deg2rad(1.0))
_MIN_SPEED_FRACTION = 1e-3


def _conf_text(conf: Conf) -> str:
    return f"[{','.join(str(c) for c in conf)}]"


def _straight(
    kin: Kinematics, q0: np.ndarray, T_end: np.ndarray, T_tcp: np.ndarray
) -> tuple[np.ndarray | None, float, float]:
    """Follow the straight TCP line from q0 (6,) to T_end (4, 4) with the IK, seeded from the
    previous sample: (q at the end or None, the fraction of the line reached, the residual
    [m] where it failed)."""
    T0 = kin.fk(q0) @ T_tcp
    dist = float(np.linalg.norm(T_end[:3, 3] - T0[:3, 3]))
    R = T0[:3, :3].T @ T_end[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    n = max(8, math.ceil(dist / _LINE_STEP_M), math.ceil(angle / _LINE_STEP_RAD))
    s = np.arange(1, n + 1) / n
    q = np.array(q0, dtype=float)
    for k, T in enumerate(straight_path(T0, T_end, s)):
        r = kin.ik(T, q, T_tcp, extra_seeds=0)
        if not r.success or np.max(np.abs(r.q - q)) > MAX_JOINT_STEP_RAD:
            return None, float(s[k - 1]) if k else 0.0, r.position_error_m
        q = r.q
    return q, 1.0, 0.0


def speed_fraction(
    kin: Kinematics,
    q0: np.ndarray,
    q1: np.ndarray,
    T_tcp: np.ndarray,
    v_tcp_m_s: float,
    v_ori_rad_s: float,
    joint_speed: np.ndarray,
) -> float:
    """The fraction of the joints' speed limits at which a joint move from q0 to q1 brings
    the TCP's peak speed to v_tcp (and its reorientation to v_ori): with every joint's peak
    speed at f times the limits the slowest joint takes t = max |dq| / speed / f at peak
    speed, and the TCP travels its path of length L (sampled with FK) at about L / t."""
    dq = np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float)
    t_unit = float(np.max(np.abs(dq) / joint_speed))
    if t_unit <= 0.0:
        return 1.0
    points = np.array([(kin.fk(q0 + s * dq) @ T_tcp)[:3, 3] for s in np.linspace(0, 1, 9)])
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    R = (kin.fk(q0) @ T_tcp)[:3, :3].T @ (kin.fk(q1) @ T_tcp)[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    fraction = 1.0
    if length > 1e-9:
        fraction = min(fraction, v_tcp_m_s * t_unit / length)
    if angle > 1e-9:
        fraction = min(fraction, v_ori_rad_s * t_unit / angle)
    return float(np.clip(fraction, _MIN_SPEED_FRACTION, 1.0))


def solve_move(
    module: ModuleScope,
    step: Step,
    kin: Kinematics,
    T_base_tcp: np.ndarray,
    T_tcp: np.ndarray,
    conf: Conf | None,
    target_conf: Conf,
    state: PlanState,
    seed: int,
) -> np.ndarray:
    """The joints of a MoveJ (in `conf`) or the end of a MoveL (along the line, then checked
    against `conf`); raises RapidError naming the line if the nominal arm cannot."""
    assert step.move is not None
    what = f"{step.instruction} {step.move.target}"
    p = ", ".join(f"{v * 1e3:.1f}" for v in T_base_tcp[:3, 3])
    if step.instruction.casefold() == "movel":
        q, reached, residual = _straight(kin, state.q, T_base_tcp, T_tcp)
        if q is None:
            anywhere = solve_in_configuration(kin, T_base_tcp, T_tcp, None, state.q, seed)
            if not anywhere.reachable:
                raise program_error(
                    module,
                    step.line,
                    f"{what}: the nominal arm cannot reach the target (TCP at [{p}] mm in the "
                    f"base frame; IK residual {anywhere.residual_m * 1e3:.3g} mm)",
                )
            raise program_error(
                module,
                step.line,
                f"{what}: the nominal arm cannot follow the straight line to the target: it "
                f"fails at {reached * 100:.0f}% of the line (residual {residual * 1e3:.3g} mm, "
                "or a configuration flip)",
            )
        if conf is not None and not honours(kin, q, conf):
            raise program_error(
                module,
                step.line,
                f"{what}: the straight line from the previous point ends in configuration "
                f"{_conf_text(configuration(kin, q))}, the robtarget asks for "
                f"{_conf_text(conf)} (ConfL\\On: a controller stops with a configuration "
                "error; program a MoveJ to the target, or ConfL\\Off)",
            )
        return q
    solution = solve_in_configuration(kin, T_base_tcp, T_tcp, conf, state.q, seed)
    if not solution.reachable:
        raise program_error(
            module,
            step.line,
            f"{what}: the nominal arm cannot reach the target (TCP at [{p}] mm in the base "
            f"frame; IK residual {solution.residual_m * 1e3:.3g} mm)",
        )
    if solution.q is None:
        found = ", ".join(_conf_text(c) for c in solution.found)
        raise program_error(
            module,
            step.line,
            f"{what}: the nominal arm has no solution in configuration "
            f"{_conf_text(target_conf)} within its joint limits; its solutions for this pose "
            f"are in {found} (ConfJ\\On: a controller stops here; correct the robtarget's "
            "confdata, or run with ConfJ\\Off to take the nearest solution)",
        )
    return solution.q
