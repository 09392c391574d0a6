"""Absolute orientation: Horn's closed-form unit-quaternion solution, weighted.

Finds R, t minimising sum_i w_i |x_i - (R p_i + t)|^2 (eq. 6 of the seed paper) for paired
points. The weights enter the centroids and the cross-covariance. The quaternion method
always returns a proper rotation (det R = +1), never a reflection.
"""

from __future__ import annotations

import numpy as np

from registration.registration_errors import InputError
from registration.rigid import Array


def quaternion_to_matrix(q: Array) -> Array:
    """Unit quaternions (K, 4) in (w, x, y, z) order -> rotations (K, 3, 3)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    R = np.empty((len(q), 3, 3))
    R[:, 0, 0] = w * w + x * x - y * y - z * z
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = w * w - x * x + y * y - z * z
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = w * w - x * x - y * y + z * z
    return R


def absolute_orientation_batch(
    data: Array, model: Array, weights: Array | None = None
) -> tuple[Array, Array]:
    """Horn's solution for K independent problems at once.

    Args:
        data: points p (K, N, 3) to be moved.
        model: corresponding points x (K, N, 3).
        weights: non-negative weights (K, N); uniform if None. Rows summing to zero give
            the identity rotation and zero translation.

    Returns:
        R (K, 3, 3) and t (K, 3) with x ~ R p + t.
    """
    K, N, _ = data.shape
    w = np.ones((K, N)) if weights is None else np.asarray(weights, dtype=float)
    wsum = w.sum(axis=1)
    safe = np.where(wsum > 0, wsum, 1.0)
    p_mean = np.einsum("kn,knd->kd", w, data) / safe[:, None]
    x_mean = np.einsum("kn,knd->kd", w, model) / safe[:, None]
    P = data - p_mean[:, None, :]
    X = model - x_mean[:, None, :]
    S = np.einsum("kn,kna,knb->kab", w, P, X)  # S[a, b] = sum w p_a x_b
    Sxx, Sxy, Sxz = S[:, 0, 0], S[:, 0, 1], S[:, 0, 2]
    Syx, Syy, Syz = S[:, 1, 0], S[:, 1, 1], S[:, 1, 2]
    Szx, Szy, Szz = S[:, 2, 0], S[:, 2, 1], S[:, 2, 2]
    Nm = np.empty((K, 4, 4))
    Nm[:, 0, 0] = Sxx + Syy + Szz
    Nm[:, 0, 1] = Nm[:, 1, 0] = Syz - Szy
    Nm[:, 0, 2] = Nm[:, 2, 0] = Szx - Sxz
    Nm[:, 0, 3] = Nm[:, 3, 0] = Sxy - Syx
    Nm[:, 1, 1] = Sxx - Syy - Szz
    Nm[:, 1, 2] = Nm[:, 2, 1] = Sxy + Syx
    Nm[:, 1, 3] = Nm[:, 3, 1] = Szx + Sxz
    Nm[:, 2, 2] = -Sxx + Syy - Szz
    Nm[:, 2, 3] = Nm[:, 3, 2] = Syz + Szy
    Nm[:, 3, 3] = -Sxx - Syy + Szz
    _, vecs = np.linalg.eigh(Nm)
    q = vecs[:, :, -1]
    R = quaternion_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))
    R[wsum <= 0] = np.eye(3)
    t = x_mean - np.einsum("kab,kb->ka", R, p_mean)
    return R, t


def absolute_orientation(
    data: Array, model: Array, weights: Array | None = None
) -> tuple[Array, Array]:
    """Weighted Horn solution for one problem: x_i ~ R p_i + t.

    Args:
        data: points p (N, 3).
        model: corresponding points x (N, 3), same order.
        weights: non-negative weights (N,), uniform if None.

    Returns:
        R (3, 3), det R = +1, and t (3,).
    """
    data = np.asarray(data, dtype=float)
    model = np.asarray(model, dtype=float)
    if data.ndim != 2 or data.shape[1] != 3 or model.shape != data.shape:
        raise InputError(
            f"absolute orientation needs two (N, 3) arrays of equal shape; got {data.shape} "
            f"and {model.shape}"
        )
    if weights is not None:
        weights = np.asarray(weights, dtype=float)
        if weights.shape != (len(data),) or np.any(weights < 0) or not weights.sum() > 0:
            raise InputError(
                f"weights must be {len(data)} non-negative numbers with a positive sum; got "
                f"shape {weights.shape}"
            )
        weights = weights[None]
    R, t = absolute_orientation_batch(data[None], model[None], weights)
    return R[0], t[0]
