"""Quality of a registration: pose covariance and predicted target registration error.

RMS alone does not reveal a wrong minimum or a poorly constrained pose. The covariance of
the pose comes from the point-to-plane Jacobian of the final inliers and the residual
variance; the predicted TRE at a target x is the RMS of the displacement of x under that
covariance (verdict.py turns these figures into a verdict).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from registration.registration_errors import InputError
from registration.rigid import Array, skew


def trimmed_rms(residuals: Array, trim: float) -> Array:
    """RMS of the smallest `trim` fraction of |residuals| along the last axis, shape (...,).

    The cost that ranks minima: robust to outliers and to data that cover only part of the
    model, as long as more than `trim` of the points fit.
    """
    n = residuals.shape[-1]
    k = max(1, int(np.ceil(trim * n)))
    part = np.partition(np.abs(residuals), k - 1, axis=-1)[..., :k]
    return np.sqrt(np.mean(part**2, axis=-1))


@dataclass(frozen=True)
class ResidualCorrelation:
    """How the residuals of a fit split into white noise and spatially correlated error.

    A scan's residuals are not independent: the model error of a CT-derived or machined
    surface, and the arm's error during a pass, move whole regions together. Treating them
    as independent makes the pose look far more certain than it is.

    Attributes:
        sigma_white: standard deviation of the uncorrelated part [length units].
        sigma_correlated: standard deviation of the correlated part [length units].
        length: correlation length of the correlated part [length units].
    """

    sigma_white: float
    sigma_correlated: float
    length: float


def residual_correlation(
    points: Array, residuals: Array, seed: int = 0, pairs: int = 20000
) -> ResidualCorrelation:
    """Estimate white and correlated residual parts from the empirical variogram.

    gamma(d) = 1/2 E[(r_i - r_j)^2] over pairs at distance d rises from the white variance
    (the nugget, at the shortest distances) to the total variance (the sill); the correlation
    length is where it has covered 1 - 1/e of the way.

    Args:
        points: points where the residuals were taken (N, 3).
        residuals: residuals (N,) of the inliers [length units].
    """
    n = len(points)
    if n == 0:
        return ResidualCorrelation(0.0, 0.0, 0.0)
    total = float(np.mean(residuals**2))
    if n < 30:
        return ResidualCorrelation(np.sqrt(total), 0.0, 0.0)
    rng = np.random.default_rng(seed)
    tree = cKDTree(points)
    anchors = rng.choice(n, size=min(n, 1500), replace=False)
    _, near = tree.query(points[anchors], k=min(9, n))
    i_short = np.repeat(anchors, near.shape[1] - 1)
    j_short = near[:, 1:].ravel()
    i_long, j_long = rng.integers(n, size=pairs), rng.integers(n, size=pairs)
    i = np.concatenate([i_short, i_long])
    j = np.concatenate([j_short, j_long])
    keep = i != j
    d = np.linalg.norm(points[i[keep]] - points[j[keep]], axis=1)
    g = 0.5 * (residuals[i[keep]] - residuals[j[keep]]) ** 2
    edges = np.geomspace(max(d.min(), 1e-12), d.max() * 1.0001, 13)
    which = np.digitize(d, edges) - 1
    centers, gamma = [], []
    for b in range(len(edges) - 1):
        in_bin = which == b
        if in_bin.sum() >= 30:
            centers.append(np.sqrt(edges[b] * edges[b + 1]))
            gamma.append(float(np.mean(g[in_bin])))
    if len(gamma) < 2:
        return ResidualCorrelation(np.sqrt(total), 0.0, 0.0)
    nugget = min(gamma[0], total)
    correlated = max(total - nugget, 0.0)
    reach = nugget + (1.0 - np.exp(-1.0)) * correlated
    length = next((c for c, v in zip(centers, gamma, strict=True) if v >= reach), centers[-1])
    return ResidualCorrelation(float(np.sqrt(nugget)), float(np.sqrt(correlated)), float(length))


@dataclass(frozen=True)
class ScanPasses:
    """The data came in passes, each displaced as a whole by an unknown offset.

    A robot scans in passes; its absolute accuracy moves each pass by a few tenths of a
    millimetre, the same for every point of the pass. Such an offset is not noise that
    averages out over the points of the pass, and the residuals cannot reveal it where the
    passes do not overlap: the covariance takes it from the arm's specification.

    Attributes:
        labels: pass of each data point (N,), any integers.
        sigma_offset: standard deviation of a pass's offset along each axis [length units].
    """

    labels: Array
    sigma_offset: float

    def __post_init__(self) -> None:
        labels = np.asarray(self.labels)
        if labels.ndim != 1:
            raise InputError(f"pass labels must be a 1-D array; got shape {labels.shape}")
        if not np.isfinite(self.sigma_offset) or self.sigma_offset < 0:
            raise InputError(f"sigma_offset must be a finite number >= 0; got {self.sigma_offset}")


def _jacobians(points: Array, normals: Array | None) -> Array:
    """Residual Jacobians w.r.t. (dt, dtheta): (N, 1, 6) point-to-plane or (N, 3, 6)."""
    if normals is not None:
        return np.concatenate([normals, np.cross(points, normals)], axis=1)[:, None, :]
    return np.concatenate([np.broadcast_to(np.eye(3), (len(points), 3, 3)), -skew(points)], axis=2)


def pose_covariance(
    points: Array,
    normals: Array | None,
    weights: Array,
    sigma: float,
    correlation: ResidualCorrelation | None = None,
    passes: ScanPasses | None = None,
) -> Array:
    """Covariance (6, 6) of a small pose correction (dt, dtheta) applied in the model frame.

    The weighted least-squares estimate is dx = H^-1 sum_i w_i J_i^T r_i, so its covariance
    is H^-1 (sum_ij w_i w_j J_i^T C_ij J_j) H^-1. With white residuals, C = sigma^2 I. With a
    correlated part, points closer than about 2.5 correlation lengths (one voxel) are taken
    as fully correlated and farther ones as independent.

    Args:
        points: registered data points in the model frame (N, 3).
        normals: model normals at their closest points (N, 3) (point-to-plane residuals), or
            None (point-to-point residuals, 3 per point).
        weights: robust weights (N,).
        sigma: standard deviation of one residual component if `correlation` is None.
        correlation: white and correlated parts of the residuals.
        passes: the scan passes and the standard deviation of their rigid offsets; each
            pass g adds H^-1 A_g S A_g^T H^-1, A_g = sum_(i in g) w_i J_i^T J_i, S the
            offset covariance (translation only).
    """
    J = _jacobians(points, normals)
    H = np.einsum("nki,n,nkj->ij", J, weights, J)
    vals, vecs = np.linalg.eigh(H)
    floor = max(vals[-1], 1e-300) * 1e-12
    H_inv = (vecs / np.maximum(vals, floor)) @ vecs.T
    Jw = J * weights[:, None, None]
    if correlation is None:
        covariance = sigma**2 * H_inv
    else:
        middle = correlation.sigma_white**2 * np.einsum("nki,nkj->ij", Jw, Jw)
        if correlation.sigma_correlated > 0 and correlation.length > 0:
            size = 2.5 * correlation.length
            cell = np.floor(points / size).astype(np.int64)
            cell -= cell.min(axis=0)
            span = cell.max(axis=0) + 1
            key = (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]
            _, patch = np.unique(key, return_inverse=True)
            g = np.zeros((patch.max() + 1, J.shape[1], 6))
            np.add.at(g, patch.ravel(), Jw)
            middle += correlation.sigma_correlated**2 * np.einsum("pki,pkj->ij", g, g)
        covariance = H_inv @ middle @ H_inv
    if passes is not None and passes.sigma_offset > 0:
        labels = np.asarray(passes.labels)
        if labels.shape != (len(points),):
            raise InputError(
                f"pass labels must have one entry per data point ({len(points)}); got "
                f"{labels.shape}"
            )
        S = np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]) * passes.sigma_offset**2
        for label in np.unique(labels):
            in_pass = labels == label
            A = np.einsum("nki,nkj->ij", Jw[in_pass], J[in_pass])
            M = H_inv @ A
            covariance = covariance + M @ S @ M.T
    return covariance


def target_covariance(covariance: Array, targets: Array) -> Array:
    """Covariance (K, 3, 3) of the displacement of targets (K, 3) in the model frame under a
    pose error of covariance (6, 6) (dt, dtheta): J C J^T with J = [I, -[x]x]."""
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    if targets.shape[1] != 3 or not np.isfinite(targets).all():
        raise InputError(f"targets must be a finite (K, 3) array; got shape {targets.shape}")
    J = np.concatenate(
        [np.broadcast_to(np.eye(3), (len(targets), 3, 3)), -skew(targets)], axis=2
    )  # (K, 3, 6)
    return J @ covariance @ J.transpose(0, 2, 1)


def predicted_tre(covariance: Array, targets: Array) -> Array:
    """Predicted target registration error (K,) at targets (K, 3) in the model frame [length].

    The displacement of x under a pose error (dt, dtheta) is dt + dtheta x x; its RMS
    (square root of the trace of its covariance) is the predicted TRE.
    """
    cov_x = target_covariance(covariance, targets)
    return np.sqrt(np.trace(cov_x, axis1=1, axis2=2))
