"""The best pose assessed: its quality from its own residuals, and the verdict.

Step 3 of `match` (matcher.py), after the refinement: the residuals, the inlier fractions,
the covariance and the predicted TRE (quality.py), and the verdict for the model or for each
target (verdict.py).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from registration.judge import fits, surface_residuals
from registration.match_request import MatchRequest
from registration.match_work import MatchWork
from registration.minima import Judged
from registration.quality import ScanPasses, pose_covariance, predicted_tre, residual_correlation
from registration.rigid import Array, transform_points
from registration.verdict import (
    TargetPrediction,
    Verdict,
    assess_targets,
    fit_rejection,
    model_verdict,
)


@dataclass(frozen=True, eq=False)
class PoseQuality:
    """The quality of a pose from its own residuals: RMS of the inliers' residuals, the
    inlier fraction, the fraction of the scan's surface points near the model that fit, the
    residual scale, the pose covariance (6, 6) and the worst predicted TRE over the model."""

    rms: float
    inlier_fraction: float
    surface_fit: float
    sigma: float
    covariance: Array
    worst_tre: float


def _quality(
    T_model_data: Array, w: MatchWork, seed: int, passes: ScanPasses | None
) -> PoseQuality:
    """The quality of the pose T_model_data on the points `w.work` (N, 3) (those of them on
    a surface: `w.strict_surface` (N,)), `passes` the passes' labels of those points."""
    p = transform_points(T_model_data, w.work)
    closest = w.exact(p)
    residuals = surface_residuals(closest, p)
    inliers = fits(closest, residuals, w.floor)
    weights = closest.weights(residuals, w.kernel)
    inlier_fraction = float(inliers.mean())
    # The scan's surface points near the model (within the reach: clutter beside the object
    # is no evidence against the pose; a wrong object's surface, a few millimetres off the
    # model's, is) and the fraction of them that fit.
    near_surface = w.strict_surface & (closest.distances < w.reach)
    surface_fit = float(inliers[near_surface].mean()) if near_surface.any() else inlier_fraction
    rms = float(np.sqrt(np.mean(residuals[inliers] ** 2))) if inliers.any() else float("inf")
    dof = max(int(inliers.sum()) - 6, 1)
    sigma = float(np.sqrt(np.sum(weights * residuals**2) / max(weights.sum(), 1e-300)))
    sigma *= np.sqrt(inliers.sum() / dof) if inliers.any() else 1.0
    sigma = max(sigma, w.floor)
    correlation = residual_correlation(p[inliers], residuals[inliers], seed=seed)
    if correlation.sigma_white < w.floor:
        correlation = type(correlation)(w.floor, correlation.sigma_correlated, correlation.length)
    covariance = pose_covariance(p, closest.normals, weights, sigma, correlation, passes)
    samples = w.shape.samples
    worst_tre = float(np.max(predicted_tre(covariance, samples[:: max(1, len(samples) // 2000)])))
    return PoseQuality(rms, inlier_fraction, surface_fit, sigma, covariance, worst_tre)


@dataclass(frozen=True, eq=False)
class Assessment:
    """The best pose's quality, why its fit is rejected (None if it is not), the
    per-target prediction (with targets), and the verdict with its reason."""

    quality: PoseQuality
    fit_rejection: str | None
    targets: TargetPrediction | None
    verdict: Verdict
    reason: str


def assess(
    request: MatchRequest,
    w: MatchWork,
    T_model_data: Array,
    judged: Judged,
    stage: dict[str, float],
) -> Assessment:
    """The quality of the best pose T_model_data (4, 4) from its own residuals, and the
    verdict: the worst target's, or the model's without targets."""
    t0 = time.perf_counter()
    passes = request.passes
    q = _quality(T_model_data, w, request.seed,
                 None if passes is None else ScanPasses(np.asarray(passes.labels)[w.used],
                                                       passes.sigma_offset))  # fmt: skip
    extent, acceptance, targets = w.shape.extent, request.acceptance, request.targets
    fit_reason = fit_rejection(q.rms, q.inlier_fraction, q.surface_fit, extent, acceptance)
    prediction = None
    if targets is not None:
        prediction = assess_targets(
            targets, predicted_tre(q.covariance, targets), fit_reason, judged.symmetries,
            judged.rivals, extent, acceptance,
        )  # fmt: skip
        verdict, reason = _worst_target(prediction.verdict, prediction.reason)
    else:
        verdict, reason = model_verdict(
            fit_reason, judged.symmetries, judged.ambiguity, q.worst_tre,
            request.mode != "refine", extent, acceptance,
        )  # fmt: skip
    stage["quality"] = time.perf_counter() - t0
    return Assessment(q, fit_reason, prediction, verdict, reason)


def _worst_target(verdicts: tuple[str, ...], reasons: tuple[str, ...]) -> tuple[Verdict, str]:
    """The overall verdict with targets: the worst target's, with its reason."""
    for level in ("rejected", "ambiguous"):
        bad = [k for k, v in enumerate(verdicts) if v == level]
        if bad:
            return level, f"target {bad[0]}: {reasons[bad[0]]}" + (
                f" ({len(bad)} of {len(verdicts)} targets {level})" if len(bad) > 1 else ""
            )
    return "accepted", f"all {len(verdicts)} targets located: good fit, well-constrained pose"
