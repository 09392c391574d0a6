"""Haralick's robust estimator for paired points (seed paper, eq. 6-8, the Q operator).

Iteratively reweighted absolute orientation: residuals -> Tukey weights -> weighted Horn,
until the change of the weighted mean squared error falls below tau.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration.horn import absolute_orientation
from registration.kernels import Kernel, Tukey
from registration.registration_errors import InputError
from registration.rigid import Array, make_T


@dataclass(frozen=True)
class RobustFit:
    """Result of the robust paired-point fit.

    Attributes:
        T_model_data: (4, 4) maps data points into the model frame.
        weights: final weights (N,), in [0, 1].
        mse: final weighted mean squared error [length^2].
        iterations: reweighting iterations run.
        converged: True if the stopping rule held before the iteration cap.
    """

    T_model_data: Array
    weights: Array
    mse: float
    iterations: int
    converged: bool


def haralick(
    data: Array,
    model: Array,
    kernel: Kernel | None = None,
    tau: float = 1e-12,
    max_iterations: int = 50,
) -> RobustFit:
    """Robust rigid fit of paired points, x_i ~ R p_i + t, with outliers down-weighted.

    Args:
        data: points p (N, 3).
        model: corresponding points x (N, 3).
        kernel: robust kernel; Tukey(c=8) by default.
        tau: stop when |d_k - d_{k+1}| < tau, d the weighted mean squared error [length^2].
        max_iterations: iteration cap.
    """
    kernel = kernel or Tukey()
    data = np.asarray(data, dtype=float)
    model = np.asarray(model, dtype=float)
    if data.ndim != 2 or data.shape[1] != 3 or model.shape != data.shape or len(data) < 3:
        raise InputError(
            f"paired fit needs two (N, 3) arrays of equal shape with N >= 3; got {data.shape} "
            f"and {model.shape}"
        )
    R, t = absolute_orientation(data, model)
    weights = np.ones(len(data))
    previous = np.inf
    for k in range(1, max_iterations + 1):
        residuals = np.linalg.norm(model - (data @ R.T + t), axis=1)
        weights = kernel.weights(residuals)
        if weights.sum() <= 0:
            weights = np.ones(len(data))
        R, t = absolute_orientation(data, model, weights)
        residuals = np.linalg.norm(model - (data @ R.T + t), axis=1)
        mse = float(np.sum(weights * residuals**2) / weights.sum())
        if abs(previous - mse) < tau:
            return RobustFit(make_T(R, t), weights, mse, k, True)
        previous = mse
    return RobustFit(make_T(R, t), weights, previous, max_iterations, False)
