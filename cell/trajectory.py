"""Time-scaled trajectories: quintic point-to-point joint moves and straight TCP paths.

Sampled at the physics step `dt` [s]; positions (K, n) and velocities (K, n) are returned
so that the servos get a velocity feed-forward.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

#: Peak of the quintic profile's velocity, relative to the mean velocity.
QUINTIC_PEAK = 1.875


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
