"""Iterative closest point with the Q and C operators of the seed paper (eq. 19-23).

Each iteration finds the closest model points to the moved data (C), weights the pairs with a
robust kernel, and solves for the rigid step (Q): Horn's method (point-to-point) or the
linearised point-to-plane system. It stops when the weighted mean squared error changes by
less than tau between two iterations (eq. 21), when a step moves the points by less than
`min_step`, or at the iteration cap.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from registration.horn import absolute_orientation
from registration.kernels import Kernel, Tukey
from registration.registration_errors import InputError
from registration.rigid import Array, exp_se3, make_T, transform_points
from registration.shapes.base import Closest, Shape, check_points

Variant = Literal["point_to_point", "point_to_plane"]
VARIANTS: tuple[str, ...] = ("point_to_point", "point_to_plane")


@dataclass(frozen=True)
class IcpResult:
    """One ICP run.

    Attributes:
        T_model_data: (4, 4) maps data points into the model frame.
        residuals: final residuals (N,): distances (point-to-point) or signed distances along
            the model normal (point-to-plane) [length units].
        weights: final robust weights (N,) in [0, 1].
        mse_history: weighted mean squared error per iteration [length^2].
        iterations: iterations run.
        converged: True if |d_k - d_k+1| < tau, or a step below min_step, before the cap.
    """

    T_model_data: Array
    residuals: Array
    weights: Array
    mse_history: Array
    iterations: int
    converged: bool

    @property
    def rms(self) -> float:
        """Weighted RMS of the final residuals [length units]."""
        w = self.weights
        return float(np.sqrt(np.sum(w * self.residuals**2) / max(w.sum(), 1e-300)))


def point_to_plane_step(p: Array, q: Array, n: Array, w: Array) -> Array:
    """Rigid step (4, 4) minimising sum w (n . (R p + t - q))^2, linearised about p's centroid.

    Args:
        p: moved data points (N, 3); q: closest model points (N, 3); n: model normals (N, 3);
        w: weights (N,).
    """
    c0 = np.sum(w[:, None] * p, axis=0) / max(w.sum(), 1e-300)
    pc = p - c0
    J = np.concatenate([n, np.cross(pc, n)], axis=1)  # (N, 6): d r / d (t, omega)
    r = np.einsum("nd,nd->n", n, p - q)
    A = J.T @ (w[:, None] * J)
    b = -J.T @ (w * r)
    A += np.eye(6) * (1e-12 * np.trace(A) + 1e-300)
    xi = np.linalg.solve(A, b)
    step = exp_se3(xi)
    # Rotate about the centroid: x' = R (x - c0) + c0 + t.
    return make_T(step[:3, :3], c0 - step[:3, :3] @ c0 + step[:3, 3])


def icp(
    data: Array,
    model: Shape,
    T_init: Array | None = None,
    variant: Variant = "point_to_plane",
    kernel: Kernel | None = None,
    tau: float | None = None,
    min_step: float = 0.0,
    max_iterations: int = 60,
    callback: object | None = None,
    closest: Callable[[Array], Closest] | None = None,
) -> IcpResult:
    """Register data points to a model shape from one initial state.

    Args:
        data: measured points P (N, 3), any N >= 3; no correspondence with the model needed.
        model: a Shape (points, segments, mesh or parametric surface).
        T_init: initial transform (4, 4) of the data into the model frame; identity if None.
        variant: "point_to_point" or "point_to_plane" (needs model normals).
        kernel: robust kernel (Tukey by default; L2 for plain least squares).
        tau: threshold of eq. 21 on the change of the weighted mean squared error
            [length^2]; default (1e-5 * model extent)^2.
        min_step: stop when a step moves the data points by less than this (RMS) [length
            units]: the robust scale can go on shrinking, and the error with it, long after
            the pose has stopped moving. 0: eq. 21 alone.
        max_iterations: iteration cap.
        callback: optional callable(iteration, T_model_data, mse) for progress or logging.
        closest: the closest-point operator; the model's exact C operator by default
            (`model.near` for fast iterations while the pose is still far).
    """
    data = check_points(data, "data points", minimum=3)
    if variant not in VARIANTS:
        raise InputError(f"unknown ICP variant {variant!r}; valid: {', '.join(VARIANTS)}")
    if variant == "point_to_plane" and not model.has_normals:
        variant = "point_to_point"
    kernel = kernel or Tukey(min_scale=1e-6 * model.extent)
    tau = (1e-5 * model.extent) ** 2 if tau is None else tau
    closest = closest or model.closest
    T = np.eye(4) if T_init is None else np.asarray(T_init, dtype=float).copy()
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise InputError(f"T_init must be a finite (4, 4) matrix; got shape {T.shape}")
    history: list[float] = []
    residuals = np.zeros(len(data))
    weights = np.ones(len(data))
    converged = False
    for _ in range(max_iterations):
        p = transform_points(T, data)
        c = closest(p)
        if variant == "point_to_plane":
            assert c.normals is not None
            residuals = np.einsum("nd,nd->n", c.normals, p - c.points)
        else:
            residuals = c.distances
        weights = c.weights(residuals, kernel)
        if weights.sum() <= 0:
            weights = np.ones(len(data))
        mse = float(np.sum(weights * residuals**2) / weights.sum())
        if callable(callback):
            callback(len(history), T, mse)
        if history and abs(history[-1] - mse) < tau:
            history.append(mse)
            converged = True
            break
        history.append(mse)
        if variant == "point_to_plane":
            assert c.normals is not None
            step = point_to_plane_step(p, c.points, c.normals, weights)
        else:
            R, t = absolute_orientation(p, c.points, weights)
            step = make_T(R, t)
        T = step @ T
        if min_step > 0:
            moved = transform_points(step, p) - p
            if float(np.sqrt(np.mean(np.einsum("nd,nd->n", moved, moved)))) < min_step:
                converged = True
                break
    return IcpResult(T, residuals, weights, np.asarray(history), len(history), converged)
