"""The error budget of a job's targets, from what the job itself measured, before the first
touch.

Four terms at each target, each a standard error (an RMS length) [m], add in quadrature:
- `tre`: the registration's predicted TRE there (registration.quality: the scan's noise, its
  correlated part and the passes' offsets through the match's geometry);
- `arm`: the calibrated arm's error at a target: the job's budget for it
  (`verify.arm_accuracy_m`, a data sheet's figure, or the cell's own `verify.budget.arm_m`
  where its campaigns show its arm worse), or the calibration's own point residual if it
  fits worse than that; a calibration an earlier job made, kept because its quick check
  passed, adds in quadrature the drift the check measured since, with its uncertainty
  (scenarios.results.calibration_check_result.DriftCheck.kept_error_m);
- `tool`: what the tool's check at the beam left: its reading and, per axis, its own
  standard deviation;
- `model`: how far the real surface lies from the model there: the RMS of the scan's
  residuals within LOCAL_RADIUS_M of the target (the model's error where the scan sees it,
  the laser's noise in it), never less than the model's tolerance as the job file states it
  (`model.tolerance_m`, a two-sided 95 % figure: half of it is one standard error).

A target's bound is its sigma times `verify.budget.k_target`, and the run's RMS bound the
targets' RMS sigma times `k_rms`: coverage factors calibrated on campaigns so that the
bounds cover the true error at 95 % of targets and of runs (bench/budget_coverage.py).
"""

from __future__ import annotations

import numpy as np

from models.model import ObjectModel
from registration import MeshModel, transform_points
from scenarios.offline.settings import PlanningSettings
from scenarios.results.budget_result import ErrorBudget, TargetBudget
from scenarios.results.verification_result import TcpCheck

#: The scan's points within this distance of a target measure the model's error there [m].
LOCAL_RADIUS_M = 0.01
#: Fewer points than this near a target leave its model term to the stated tolerance.
MIN_LOCAL_POINTS = 20


def local_model_error(
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    points_table: np.ndarray,
    targets_object: np.ndarray,
    radius_m: float = LOCAL_RADIUS_M,
) -> np.ndarray:
    """The RMS distance [m] of the scan's points (M, 3), nominal table frame, from the model
    placed at T_table_object (4, 4), over the points within `radius_m` of each target (K, 3)
    in the object's frame; NaN where fewer than MIN_LOCAL_POINTS are that near."""
    out = np.full(len(targets_object), np.nan)
    if len(points_table) == 0 or len(targets_object) == 0:
        return out
    points = transform_points(np.linalg.inv(T_table_object), np.asarray(points_table, float))
    near = [np.flatnonzero(np.linalg.norm(points - p, axis=1) <= radius_m) for p in targets_object]
    wanted = np.unique(np.concatenate(near)) if near else np.empty(0, int)
    if len(wanted) == 0:
        return out
    mesh = MeshModel(virtual.mesh.vertices, virtual.mesh.faces, sample_count=1000)
    distances = np.zeros(len(points))
    distances[wanted] = mesh.closest(points[wanted]).distances
    for k, idx in enumerate(near):
        if len(idx) >= MIN_LOCAL_POINTS:
            out[k] = float(np.sqrt(np.mean(distances[idx] ** 2)))
    return out


def tool_term(check: TcpCheck | None, tolerance_m: float) -> float:
    """What the tool's check left of its error [m]: its reading and its standard deviation
    on both axes in quadrature, or only the latter where the job corrected the TCP by the
    reading; without a check, the tolerance the job allows a tool (`tolerance_m` [m])."""
    if check is None:
        return tolerance_m
    if check.corrected:
        return float(np.sqrt(2.0) * check.sigma_m)
    off = check.off_m if np.isfinite(check.off_m) else check.resolves_m
    return float(np.hypot(off, np.sqrt(2.0) * check.sigma_m))


def error_budget(
    names: tuple[str, ...],
    tre_m: np.ndarray,
    local_model_m: np.ndarray,
    tool_m: float,
    calibration_residual_m: float | None,
    settings: PlanningSettings,
    kept_drift_m: float | None = None,
) -> ErrorBudget:
    """The budget of the targets `names` (K,): their predicted TRE (K,) [m], the scan's
    model error near each (K,) [m] (NaN: not seen), the tool's term [m], the calibration's
    point residual [m] (None: the arm was not calibrated) and the drift a kept calibration
    carries [m] (None: made in this job), held to the job's goals."""
    verify = settings.verify
    arm = verify.arm_accuracy_m if verify.budget.arm_m is None else verify.budget.arm_m
    if calibration_residual_m is not None:
        arm = max(arm, calibration_residual_m)
    if kept_drift_m is not None:
        arm = float(np.hypot(arm, kept_drift_m))
    stated = settings.model_tolerance_m / 2.0
    k = verify.budget
    targets = []
    for name, tre, local in zip(names, tre_m, local_model_m, strict=True):
        model = stated if not np.isfinite(local) else max(float(local), stated)
        sigma = float(np.sqrt(tre**2 + arm**2 + tool_m**2 + model**2))
        targets.append(
            TargetBudget(name, float(tre), float(arm), tool_m, model, k.k_target * sigma)
        )
    return ErrorBudget(
        tuple(targets), k.k_target, k.k_rms, settings.goal_rms_m, settings.goal_max_m
    )
