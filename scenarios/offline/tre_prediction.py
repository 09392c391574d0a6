"""The scan planner's prediction of the target registration error (TRE): the registration's
pose covariance (registration.quality.pose_covariance) from the points the chosen passes
would see, thinned as the match thins them, with the data sheet's range noise, correlated
model error and each pass's rigid offset (`ErrorModel`), and each pass's share of the
information (scenarios.offline.scan_plan).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration.quality import ResidualCorrelation, ScanPasses, pose_covariance, predicted_tre
from scenarios.offline.localization import voxel_thin
from scenarios.offline.scan_candidates import Candidate
from scenarios.offline.settings import Scan


@dataclass(frozen=True)
class ErrorModel:
    """What the planner predicts the scan's errors to be (data-sheet numbers): white range
    noise [m], correlated model error [m] and its correlation length [m], each pass's rigid
    offset per axis [m]; points thinned to one per `voxel_m` cube, at most `max_points`."""

    sigma_white_m: float
    sigma_correlated_m: float
    correlation_m: float
    pass_sigma_m: float
    voxel_m: float
    max_points: int


def error_model(section: Scan, voxel_m: float, max_points: int, pass_sigma_m: float) -> ErrorModel:
    """The planner's error model from the configuration's data-sheet numbers."""
    p = section.planning
    return ErrorModel(
        p.range_sigma_m, p.model_error_m, p.correlation_m, pass_sigma_m, voxel_m, max_points
    )


def predict_tre(
    chosen: list[Candidate], targets_model: np.ndarray, errors: ErrorModel
) -> tuple[np.ndarray, np.ndarray]:
    """The predicted TRE (K,) [m] at `targets_model` (K, 3) from the points the `chosen`
    passes would see, and the information matrix (6, 6) they give (per unit variance)."""
    if not chosen:
        return np.full(len(targets_model), np.inf), np.zeros((6, 6))
    points = np.concatenate([c.points_model for c in chosen])
    normals = np.concatenate([c.normals_model for c in chosen])
    labels = np.concatenate([np.full(len(c.points_model), k) for k, c in enumerate(chosen)])
    keep = voxel_thin(points, errors.voxel_m)
    # The match draws at most max_points of the thinned points: so many carry its information.
    scale = min(1.0, errors.max_points / max(len(keep), 1))
    p, n, lab = points[keep], normals[keep], labels[keep]
    J = np.hstack([n, np.cross(p, n)])
    info = scale * (J.T @ J)
    if len(p) < 6 or np.linalg.cond(info) > 1e12:
        return np.full(len(targets_model), np.inf), info
    weights = np.full(len(p), scale)
    correlation = ResidualCorrelation(
        errors.sigma_white_m, errors.sigma_correlated_m, errors.correlation_m
    )
    passes = ScanPasses(lab, errors.pass_sigma_m) if errors.pass_sigma_m > 0 else None
    cov = pose_covariance(p, n, weights, errors.sigma_white_m, correlation, passes)
    return predicted_tre(cov, targets_model), info


def information_shares(
    passes: list[Candidate], targets_model: np.ndarray, errors: ErrorModel
) -> list[float]:
    """Each pass' share of the plan's information: the trace of the information matrix its
    points add to the others' (after thinning), normalized to sum to one."""
    _, total = predict_tre(passes, targets_model, errors)
    shares = []
    for k in range(len(passes)):
        _, without = predict_tre(passes[:k] + passes[k + 1 :], targets_model, errors)
        shares.append(max(float(np.trace(total) - np.trace(without)), 0.0))
    norm = sum(shares) or 1.0
    return [s / norm for s in shares]
