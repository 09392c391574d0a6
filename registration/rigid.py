"""Rigid transforms as 4x4 homogeneous matrices: build, apply, compose, measure, and the
scalar-first quaternions of MuJoCo and RAPID. The project's one rigid-transform module:
`cell` and `scenarios` use it too (it depends on numpy and scipy alone)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

#: A numpy array; the docstrings give each one's shape and what it holds (floats [m], indices,
#: masks).
Array = NDArray[Any]


def make_T(R: Array, t: Array) -> Array:
    """Homogeneous transform (4, 4) from a rotation (3, 3) and a translation (3,)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def make_T_batch(R: Array, t: Array) -> Array:
    """Homogeneous transforms (K, 4, 4) from rotations (K, 3, 3) and translations (K, 3)."""
    T = np.broadcast_to(np.eye(4), (len(R), 4, 4)).copy()
    T[:, :3, :3] = R
    T[:, :3, 3] = t
    return T


def transform_points(T: Array, points: Array) -> Array:
    """Apply T (4, 4) to points (N, 3); returns (N, 3)."""
    return points @ T[:3, :3].T + T[:3, 3]


def invert(T: Array) -> Array:
    """Inverse of a rigid transform (4, 4)."""
    R = T[:3, :3]
    return make_T(R.T, -R.T @ T[:3, 3])


def rotation_angle(R: Array) -> float:
    """Angle of a rotation matrix (3, 3) [rad], in [0, pi] (accurate near 0 and pi)."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    s = np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    return float(np.arctan2(s, c))


def pose_error(T_estimate: Array, T_truth: Array) -> tuple[float, float]:
    """Rotation error [rad] and translation error [length units] between two transforms."""
    dR = T_estimate[:3, :3] @ T_truth[:3, :3].T
    return rotation_angle(dR), float(np.linalg.norm(T_estimate[:3, 3] - T_truth[:3, 3]))


def quat_wxyz_to_R(q: Array) -> Array:
    """Rotation (3, 3) of a scalar-first (w, x, y, z) quaternion: the convention of MuJoCo and
    of ABB RAPID (scipy's `from_quat` and rerun take scalar-last unless told otherwise)."""
    return Rotation.from_quat(np.asarray(q, dtype=float), scalar_first=True).as_matrix()


def R_to_quat_wxyz(R: Array) -> Array:
    """Scalar-first unit quaternion (w, x, y, z) (4,) of a rotation (3, 3), with w >= 0.

    Shepperd's method, branching on the largest of the trace and the diagonal (the
    numerically safe one); a hot path (every placement of the virtual cell's tool), where
    scipy's general-purpose Rotation costs ten times as much."""
    R = np.asarray(R, dtype=float)
    m00, m11, m22 = R[0, 0], R[1, 1], R[2, 2]
    trace = m00 + m11 + m22
    k = int(np.argmax((trace, m00, m11, m22)))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + trace)
        f = 0.25 / w
        q = np.array([w, (R[2, 1] - R[1, 2]) * f, (R[0, 2] - R[2, 0]) * f, (R[1, 0] - R[0, 1]) * f])
    elif k == 1:
        x = 0.5 * np.sqrt(1.0 + m00 - m11 - m22)
        f = 0.25 / x
        q = np.array([(R[2, 1] - R[1, 2]) * f, x, (R[0, 1] + R[1, 0]) * f, (R[0, 2] + R[2, 0]) * f])
    elif k == 2:
        y = 0.5 * np.sqrt(1.0 - m00 + m11 - m22)
        f = 0.25 / y
        q = np.array([(R[0, 2] - R[2, 0]) * f, (R[0, 1] + R[1, 0]) * f, y, (R[1, 2] + R[2, 1]) * f])
    else:
        z = 0.5 * np.sqrt(1.0 - m00 - m11 + m22)
        f = 0.25 / z
        q = np.array([(R[1, 0] - R[0, 1]) * f, (R[0, 2] + R[2, 0]) * f, (R[1, 2] + R[2, 1]) * f, z])
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def rotvecs_to_R(rotvecs: Array) -> Array:
    """Rotations (N, 3, 3) of rotation vectors (N, 3) [rad] (Rodrigues' formula)."""
    v = np.asarray(rotvecs, dtype=float).reshape(-1, 3)
    angle = np.linalg.norm(v, axis=1)
    small = angle < 1e-12
    safe = np.where(small, 1.0, angle)
    K = skew(v / safe[:, None])
    sin = np.where(small, 0.0, np.sin(angle))[:, None, None]
    cos = np.where(small, 0.0, 1.0 - np.cos(angle))[:, None, None]
    R = np.eye(3) + sin * K + cos * (K @ K)
    R[small] = np.eye(3) + skew(v[small])
    return R


def exp_se3(xi: Array) -> Array:
    """Transform (4, 4) from a twist xi = (translation (3,), rotation vector (3,)).

    The rotation part is the exponential map; the translation is applied after it
    (x' = R x + t), the parametrisation used by the linearised ICP steps.
    """
    return make_T(Rotation.from_rotvec(xi[3:]).as_matrix(), xi[:3])


def skew(v: Array) -> Array:
    """Cross-product matrices: (3,) -> (3, 3) or (N, 3) -> (N, 3, 3)."""
    v = np.asarray(v, dtype=float)
    S = np.zeros((*v.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def random_transform(rng: np.random.Generator, translation_scale: float = 1.0) -> Array:
    """A uniformly random rotation with a Gaussian translation of the given scale."""
    R = Rotation.random(random_state=rng).as_matrix()
    return make_T(R, rng.normal(scale=translation_scale, size=3))
