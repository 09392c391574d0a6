"""Quality of a registration: pose covariance, predicted target registration error, verdict.

RMS alone does not reveal a wrong minimum or a poorly constrained pose. The covariance of
the pose comes from the point-to-plane Jacobian of the final inliers and the residual
variance; the predicted TRE at a target x is the RMS of the displacement of x under that
covariance. The verdict combines the fit, the inlier fraction, the ambiguity between the
best and second-best distinct minima, and how well the pose is constrained.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from registration.errors import InputError
from registration.rigid import Array, skew

Verdict = Literal["accepted", "ambiguous", "rejected"]


def trimmed_rms(residuals: Array, trim: float) -> Array:
    """RMS of the smallest `trim` fraction of |residuals| along the last axis, shape (...,).

    The cost that ranks minima: robust to outliers and to data that cover only part of the
    model, as long as more than `trim` of the points fit.
    """
    n = residuals.shape[-1]
    k = max(1, int(np.ceil(trim * n)))
    part = np.partition(np.abs(residuals), k - 1, axis=-1)[..., :k]
    return np.sqrt(np.mean(part**2, axis=-1))


def pose_covariance(points: Array, normals: Array | None, weights: Array, sigma: float) -> Array:
    """Covariance (6, 6) of a small pose correction (dt, dtheta) applied in the model frame.

    Args:
        points: registered data points in the model frame (N, 3).
        normals: model normals at their closest points (N, 3) (point-to-plane residuals), or
            None (point-to-point residuals, 3 per point).
        weights: robust weights (N,).
        sigma: standard deviation of one residual component [length units].
    """
    if normals is not None:
        J = np.concatenate([normals, np.cross(points, normals)], axis=1)
        H = J.T @ (weights[:, None] * J)
    else:
        J3 = np.concatenate(
            [np.broadcast_to(np.eye(3), (len(points), 3, 3)), -skew(points)], axis=2
        )
        H = np.einsum("nki,n,nkj->ij", J3, weights, J3)
    vals, vecs = np.linalg.eigh(H)
    floor = max(vals[-1], 1e-300) * 1e-12
    inv = (vecs / np.maximum(vals, floor)) @ vecs.T
    return sigma**2 * inv


def predicted_tre(covariance: Array, targets: Array) -> Array:
    """Predicted target registration error (K,) at targets (K, 3) in the model frame [length].

    The displacement of x under a pose error (dt, dtheta) is dt + dtheta x x; its RMS
    (square root of the trace of its covariance) is the predicted TRE.
    """
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    if targets.shape[1] != 3 or not np.isfinite(targets).all():
        raise InputError(f"targets must be a finite (K, 3) array; got shape {targets.shape}")
    J = np.concatenate(
        [np.broadcast_to(np.eye(3), (len(targets), 3, 3)), -skew(targets)], axis=2
    )  # (K, 3, 6)
    cov_x = J @ covariance @ J.transpose(0, 2, 1)
    return np.sqrt(np.trace(cov_x, axis1=1, axis2=2))


@dataclass(frozen=True)
class Acceptance:
    """Thresholds of the verdict.

    Attributes:
        max_rms: largest acceptable inlier RMS [length units]; None: 1 % of the model extent.
        min_inlier_fraction: smallest acceptable fraction of data points that fit.
        max_ambiguity: largest acceptable ratio of best to second-best distinct minimum cost.
        max_predicted_tre: largest acceptable predicted TRE over the model surface
            [length units]; None: 2 % of the model extent.
    """

    max_rms: float | None = None
    min_inlier_fraction: float = 0.5
    max_ambiguity: float = 0.7
    max_predicted_tre: float | None = None


def decide(
    rms: float,
    inlier_fraction: float,
    ambiguity: float,
    worst_tre: float,
    extent: float,
    acceptance: Acceptance,
) -> tuple[Verdict, str]:
    """Verdict and the reason for it, in words."""
    max_rms = acceptance.max_rms if acceptance.max_rms is not None else 0.01 * extent
    max_tre = (
        acceptance.max_predicted_tre if acceptance.max_predicted_tre is not None else 0.02 * extent
    )
    if inlier_fraction < acceptance.min_inlier_fraction:
        return "rejected", (
            f"only {inlier_fraction:.0%} of the data fit the model "
            f"(needs {acceptance.min_inlier_fraction:.0%})"
        )
    if rms > max_rms:
        return "rejected", f"inlier RMS {rms:.3g} exceeds {max_rms:.3g}"
    if ambiguity > acceptance.max_ambiguity:
        return "ambiguous", (
            f"a distinct pose fits almost as well (ambiguity {ambiguity:.2f} > "
            f"{acceptance.max_ambiguity:.2f})"
        )
    if worst_tre > max_tre:
        return "ambiguous", (
            f"the pose is poorly constrained: predicted TRE up to {worst_tre:.3g} "
            f"(limit {max_tre:.3g})"
        )
    return "accepted", "good fit, unique minimum, well-constrained pose"
