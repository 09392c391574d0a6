"""The registration stage as a campaign trial: scan the real object (simulated, no cell),
match the scan to the virtual model, evaluate against the truth. One flat row per trial.

The virtual model and its MeshModel (the expensive part) are built once per worker process
and cached; the real entity (model error) and everything random are drawn from the trial's
seed.
"""

from __future__ import annotations

import time
from functools import lru_cache
from typing import Any

import numpy as np

from models.model import ObjectModel
from models.model_error import ModelErrorSpec
from models.registry import builtin_model, real_model
from registration import Acceptance, MatchResult, MeshModel, invert, match
from registration.quality import ScanPasses
from scenarios.campaign.evaluate import TrialEvaluation, evaluate_registration
from scenarios.campaign.register_config import RegisterConfig, parse_register_config
from scenarios.campaign.rows import HARM_M
from scenarios.campaign.simscan import ScanErrors, SimulatedScan, simulate_scan
from scenarios.offline.localization import stray_returns
from scenarios.realcell.placement import draw_true_pose

MAX_TARGETS = 8
"""Targets reported per trial (columns err_t0_m ... of the results table)."""


@lru_cache(maxsize=8)
def virtual_model(name: str, seed: int) -> tuple[ObjectModel, MeshModel]:
    """The virtual model `name` and its matching shape, built once per process."""
    model = builtin_model(name, seed)
    return model, MeshModel(model.mesh.vertices, model.mesh.faces)


def targets_of(model: ObjectModel) -> tuple[tuple[str, ...], np.ndarray]:
    """Names and points (K, 3) [m] of the model's targets, in the model frame: the burr
    holes' deep targets, the parts' operation frames, or (a model without targets) the eight
    points at +-25 % of the bounding box about its centre."""
    if model.burr_holes:
        return tuple(h.name for h in model.burr_holes), np.array(
            [h.p_target for h in model.burr_holes]
        )
    if model.frames:
        frames = model.frames[:MAX_TARGETS]
        return tuple(f.name for f in frames), np.array(
            [np.asarray(f.T_part_frame)[:3, 3] for f in frames]
        )
    v = np.asarray(model.mesh.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    return tuple(f"box{i}" for i in range(8)), (lo + hi) / 2 + 0.25 * signs * (hi - lo)


def _simulated_scan(
    cfg: RegisterConfig, real: ObjectModel, T_table_object: np.ndarray, rng: np.random.Generator
) -> SimulatedScan:
    """The trial's scan of the real entity at its true pose (scenarios.campaign.simscan),
    with the configuration's laser, arm and scan errors and scan faults."""
    return simulate_scan(
        np.asarray(real.mesh.vertices),
        np.asarray(real.mesh.faces),
        T_table_object,
        cfg.scan.tilts_deg,
        cfg.scan.points,
        ScanErrors(
            range_sigma=cfg.laser.sigma,
            pass_sigma=cfg.arm.pass_sigma,
            pass_rotation_sigma=cfg.arm.pass_rotation_sigma,
            jitter_sigma=cfg.arm.jitter_sigma,
            outlier_fraction=cfg.scan.outliers,
            dropout_burst=cfg.faults.laser_dropout_burst or 0.0,
            spurious_m=cfg.faults.laser_spurious or 0.0,
        ),
        rng,
        coverage=cfg.scan.coverage,
        samples=cfg.scan.samples,
        cell=cfg.scan.cell_m,
        max_incidence_deg=cfg.scan.max_incidence_deg,
    )


def _row(
    cfg: RegisterConfig,
    scanned_name: str,
    scan: SimulatedScan,
    result: MatchResult,
    evaluation: TrialEvaluation,
    names: tuple[str, ...],
    predicted: np.ndarray,
) -> dict[str, Any]:
    """The trial's row: what was scanned, the match's figures, and its errors against the
    truth (per target too)."""
    row: dict[str, Any] = {
        "case": cfg.case,
        "model": cfg.model,
        "scanned_model": scanned_name,
        "n_points": len(scan.points),
        "surface_fraction": scan.surface_fraction,
        "outlier_fraction": float(1.0 - scan.inlier.mean()),
        "verdict": result.verdict,
        "reason": result.reason,
        "accepted": int(evaluation.accepted),
        "ambiguity": result.ambiguity,
        "rms_m": result.rms,
        "inlier_fraction": result.inlier_fraction,
        "worst_predicted_tre_m": result.worst_predicted_tre,
        "rotation_error_rad": evaluation.rotation_error,
        "centroid_error_m": evaluation.centroid_error,
        "target_error_max_m": float(evaluation.target_error.max()),
        "target_error_mean_m": float(evaluation.target_error.mean()),
        "target_error_real_max_m": float(evaluation.target_error_real.max()),
        "predicted_tre_max_m": float(predicted.max()),
        "right_object": int(evaluation.right_object),
        "good": int(evaluation.good),
        "false_accept": int(evaluation.false_accept),
        "n_targets": len(names),
        "targets": ";".join(names),
    }
    ratio = evaluation.tre_ratio
    for k in range(min(len(names), MAX_TARGETS)):
        row[f"err_t{k}_m"] = float(evaluation.target_error[k])
        row[f"tre_t{k}_m"] = float(predicted[k])
        row[f"ratio_t{k}"] = float(ratio[k])
    return row


def run_register_trial(config: dict[str, Any], seed: int) -> dict[str, Any]:
    """One registration trial of the configuration `config` (a RegisterConfig dict) with
    `seed`; returns the flat metrics of the row (errors in [m], angles in [rad], times [s])."""
    t_start = time.perf_counter()
    cfg: RegisterConfig = parse_register_config(config)
    rng = np.random.default_rng([int(seed), 0x5CA9])
    virtual, shape = virtual_model(cfg.model, cfg.model_seed)
    scanned_name = cfg.scanned_model or cfg.model
    scanned = (
        virtual if scanned_name == cfg.model else virtual_model(scanned_name, cfg.model_seed)[0]
    )
    spec = ModelErrorSpec(
        deformation_rms=cfg.model_error.deformation_rms_m, noise_rms=cfg.model_error.noise_rms_m
    )
    real, error = real_model(scanned, spec, int(seed))
    T_table_object = draw_true_pose(cfg.placement, real.mesh.vertices, rng)
    scan = _simulated_scan(cfg, real, T_table_object, rng)
    acceptance = Acceptance(
        max_rms=cfg.registration.max_rms_m,
        min_inlier_fraction=cfg.registration.min_inlier_fraction,
        max_ambiguity=cfg.registration.max_ambiguity,
        max_predicted_tre=cfg.registration.max_predicted_tre_m,
    )
    passes = None
    if cfg.registration.pass_sigma_m is not None:
        passes = ScanPasses(scan.pass_index, cfg.registration.pass_sigma_m)
    names, targets = targets_of(virtual)
    result = match(
        scan.points,
        shape,
        mode=cfg.registration.mode,
        targets=targets,
        seed=seed,
        acceptance=acceptance,
        passes=passes,
    )
    predicted = result.predicted_tre(targets).tre

    # Truth, read only from here on.
    targets_real = targets + error.field(targets)
    evaluation = evaluate_registration(
        result.T_model_data,
        T_table_object,
        targets,
        targets_real,
        np.asarray(virtual.mesh.vertices).mean(axis=0),
        predicted,
        accepted=result.verdict == "accepted",
        right_object=scanned_name == cfg.model,
        threshold=cfg.false_accept_m,
    )
    row = _row(cfg, scanned_name, scan, result, evaluation, names, predicted)
    row.update(
        scan_fault_columns(
            cfg.faults.active(),
            scan.points,
            scan.pass_index,
            shape,
            invert(result.T_model_data),
            result.rms,
            evaluation.accepted,
            float(evaluation.target_error.max()),
        )
    )
    row["match_seconds"] = result.seconds
    row["trial_seconds"] = time.perf_counter() - t_start
    return row


#: A pass without a point over this stretch of its sweep (or 20 times its median spacing)
#: has lost it [m] (the register stage's twin of the cell's laser-gap check).
GAP_M = 0.01


def longest_pass_gap(points: np.ndarray, pass_index: np.ndarray) -> float:
    """The longest stretch [m] along the sweep (y) of any pass without a point, beyond
    what its point spacing explains (0 if none)."""
    worst = 0.0
    for k in np.unique(pass_index):
        y = np.sort(points[pass_index == k, 1])
        if len(y) < 3:
            continue
        gaps = np.diff(y)
        limit = max(GAP_M, 20.0 * float(np.median(gaps)))
        if gaps.max() > limit:
            worst = max(worst, float(gaps.max()))
    return worst


def scan_fault_columns(
    faults: dict[str, float],
    points: np.ndarray,
    pass_index: np.ndarray,
    shape: MeshModel,
    T_table_model: np.ndarray,
    rms_m: float,
    accepted: bool,
    target_error_max_m: float,
) -> dict[str, Any]:
    """The row's fault columns (as the full stage's, scenarios.campaign.full_stage): each
    scan fault's outcome, "register" as the stage that detected it (the pass gap for a
    dropout burst, the points off the matched model for spurious returns), and `harmed`
    (accepted with a target error beyond 1 mm)."""
    seen = {
        "laser_dropout_burst": longest_pass_gap(points, pass_index) > 0.0,
        "laser_spurious": stray_returns(points, shape, T_table_model, rms_m) > 0,
    }
    out: dict[str, Any] = {}
    for name in faults:
        if seen[name]:
            out[f"fault.{name}"] = "recovered" if accepted else "stopped"
            out[f"fault.{name}.stage"] = "register"
        else:
            out[f"fault.{name}"], out[f"fault.{name}.stage"] = "missed", "missed"
    out["harmed"] = int(accepted and target_error_max_m > HARM_M)
    return out
