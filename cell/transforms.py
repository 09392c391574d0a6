"""Homogeneous transforms and quaternions: the one place where conventions are converted.

MuJoCo quaternions are wxyz; scipy's are xyzw. Transforms are (4, 4) numpy arrays.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def make_T(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(4, 4) transform from a (3, 3) rotation and a (3,) translation [m]."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def inv_T(T: np.ndarray) -> np.ndarray:
    """Inverse of a (4, 4) rigid transform."""
    R = T[:3, :3]
    return make_T(R.T, -R.T @ T[:3, 3])


def quat_wxyz_to_R(q: np.ndarray) -> np.ndarray:
    """(3, 3) rotation from a MuJoCo (w, x, y, z) quaternion."""
    w, x, y, z = np.asarray(q, dtype=float)
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def R_to_quat_wxyz(R: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) unit quaternion of a (3, 3) rotation, w >= 0."""
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    q = np.array([w, x, y, z])
    return q if w >= 0 else -q


def T_from_pos_quat(p: np.ndarray, q_wxyz: np.ndarray) -> np.ndarray:
    """(4, 4) transform from a position [m] and a MuJoCo quaternion."""
    return make_T(quat_wxyz_to_R(q_wxyz), np.asarray(p, dtype=float))


def rotation_angle(R: np.ndarray) -> float:
    """Angle [rad] of a (3, 3) rotation (robust near 0 and pi)."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    s = np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    return float(np.arctan2(s, c))


def pose_error(T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """Position [m] and rotation [rad] distance between two (4, 4) poses."""
    dp = float(np.linalg.norm(T_a[:3, 3] - T_b[:3, 3]))
    return dp, rotation_angle(T_a[:3, :3].T @ T_b[:3, :3])
