"""Time-scaled trajectories: quintic point-to-point joint moves, straight TCP paths, and
straight TCP moves as joint set-points (the IK solved along the line: linear_trajectory).

Sampled at the physics step `dt` [s]; positions (K, n) and velocities (K, n) are returned
so that the servos get a velocity feed-forward.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from cell.cell_errors import UnreachableTargetError
from cell.kinematics import Kinematics

#: Peak of the quintic profile's velocity, relative to the mean velocity.
QUINTIC_PEAK = 1.875
#: Control period of linear moves: the IK is solved at this period [s].
LINEAR_PERIOD_S = 0.01


def quintic(n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """(s, ds/dtau) of the quintic 10t^3 - 15t^4 + 6t^5 at tau = k / n_steps, k = 1..n_steps."""
    tau = np.arange(1, n_steps + 1) / n_steps
    s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    ds = 30.0 * tau**2 * (1.0 - tau) ** 2
    return s, ds


def joint_trajectory(
    q0: np.ndarray, q1: np.ndarray, v_max: np.ndarray, dt: float, speed: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Quintic move from q0 to q1 with every joint's peak speed within `speed * v_max`.

    Returns positions (K, n) and velocities (K, n), K >= 1, the last row exactly q1.
    """
    dq = np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float)
    duration = float(np.max(QUINTIC_PEAK * np.abs(dq) / (speed * np.asarray(v_max))))
    n = max(1, math.ceil(duration / dt - 1e-9))
    s, ds = quintic(n)
    q = q0 + s[:, None] * dq
    q[-1] = q1
    return q, (ds[:, None] / (n * dt)) * dq


def straight_path(T_start: np.ndarray, T_end: np.ndarray, s: np.ndarray) -> list[np.ndarray]:
    """Poses (4, 4) along the straight line and the shortest rotation, at path fractions s."""
    rotations = Rotation.from_matrix(np.stack([T_start[:3, :3], T_end[:3, :3]]))
    R = Slerp([0.0, 1.0], rotations)(np.clip(s, 0.0, 1.0)).as_matrix()
    out = []
    for k, sk in enumerate(s):
        T = np.eye(4)
        T[:3, :3] = R[k]
        T[:3, 3] = (1.0 - sk) * T_start[:3, 3] + sk * T_end[:3, 3]
        out.append(T)
    return out


def linear_trajectory(
    kin: Kinematics,
    q0: np.ndarray,
    T_base_tcp: np.ndarray,
    T_flange_tcp: np.ndarray,
    speed_m_s: float,
    angular_speed_rad_s: float,
    joint_speed: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Joint set-points (K, 6) [rad] and velocities (K, 6) [rad/s] of a straight TCP line
    from the joints `q0` (6,) to `T_base_tcp` (4, 4), the TCP at `T_flange_tcp` (4, 4) on
    the flange: the IK solved every LINEAR_PERIOD_S along a quintic profile within
    `speed_m_s` [m/s] and `angular_speed_rad_s` [rad/s], slowed until every joint keeps
    within `joint_speed` (6,) [rad/s], and sampled at the physics step `dt` [s]. Raises
    UnreachableTargetError where the line leaves the arm's reach (or flips its
    configuration)."""
    T0 = kin.fk(q0) @ T_flange_tcp
    dist = float(np.linalg.norm(T_base_tcp[:3, 3] - T0[:3, 3]))
    R_rel = T0[:3, :3].T @ T_base_tcp[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R_rel) - 1) / 2, -1, 1)))
    duration = 1.875 * max(dist / speed_m_s, angle / angular_speed_rad_s, LINEAR_PERIOD_S)
    for _ in range(4):
        n = max(2, math.ceil(duration / LINEAR_PERIOD_S))
        s, _ds = quintic(n)
        qs = np.empty((n + 1, 6))
        qs[0] = q0
        for k, T in enumerate(straight_path(T0, T_base_tcp, s)):
            # Seeded where the joints were heading: one Newton step from there, not two.
            seed = qs[k] if k == 0 else 2.0 * qs[k] - qs[k - 1]
            r = kin.ik(T, seed, T_flange_tcp, extra_seeds=0)
            if not r.success or np.max(np.abs(r.q - qs[k])) > 0.5:
                p = T[:3, 3]
                raise UnreachableTargetError(
                    f"linear move to p_base = [{p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}] m fails at "
                    f"{100 * s[k]:.0f}% of the line: residual {r.position_error_m:.3g} m, "
                    f"{r.rotation_error_rad:.3g} rad (or a configuration flip)" + kin.at_limits(r.q)
                )
            qs[k + 1] = r.q
        peak = np.max(np.abs(np.diff(qs, axis=0)) / (duration / n) / joint_speed)
        if peak <= 1.0:
            break
        duration *= peak * 1.05
    # Linear interpolation of the IK samples at the physics step, velocity by differences.
    t_samples = np.linspace(0.0, duration, n + 1)
    n_steps = max(1, round(duration / dt))
    t = np.arange(1, n_steps + 1) * (duration / n_steps)
    q = np.stack([np.interp(t, t_samples, qs[:, j]) for j in range(6)], axis=1)
    qd = np.gradient(q, t, axis=0) if n_steps > 1 else np.zeros_like(q)
    qd[-1] = 0.0
    return q, qd
