"""The registration stage as a campaign trial: scan the real object (simulated, no cell),
match the scan to the virtual model, evaluate against the truth. One typed row per trial
(scenarios.campaign.register_row).

The trial is configured by a cell job (scenarios.configuration.job_config.JobConfig): what
it reads of the job's sections and of its `register_trial` section is in
scenarios.campaign.register_job. The virtual model and its MeshModel (the expensive part)
are built once per worker process and cached; the real entity (model error) and everything
random are drawn from the trial's seed.
"""

from __future__ import annotations

import time
from functools import lru_cache

import numpy as np

from models.model import ObjectModel
from models.registry import builtin_model, real_model
from registration import Acceptance, MatchResult, MeshModel, invert, match
from registration.quality import ScanPasses
from scenarios.campaign.evaluate import TrialEvaluation, evaluate_registration
from scenarios.campaign.register_job import RegisterTrialSetup, parse_register_job
from scenarios.campaign.register_row import (
    MAX_TARGETS,
    RegisterRow,
    ScanFaultOutcome,
    TargetRecord,
)
from scenarios.campaign.rows import HARM_M
from scenarios.campaign.simscan import DepthBuffer, ScanErrors, SimulatedScan, simulate_scan
from scenarios.offline.localization import stray_returns
from scenarios.realcell.real_placement import draw_true_pose
from scenarios.realcell.setup import model_error
from scenarios.results.edge import JsonObject


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
    setup: RegisterTrialSetup,
    real: ObjectModel,
    T_table_object: np.ndarray,
    rng: np.random.Generator,
) -> SimulatedScan:
    """The trial's scan of the real entity at its true pose (scenarios.campaign.simscan):
    the job's laser noise, the trial's arm and scan, the job's scan faults."""
    arm, scan = setup.trial.arm, setup.trial.scan
    return simulate_scan(
        np.asarray(real.mesh.vertices),
        np.asarray(real.mesh.faces),
        T_table_object,
        scan.tilts_deg,
        scan.points,
        ScanErrors(
            range_sigma=setup.job.cell.noise.laser_sigma_m,
            pass_sigma=arm.pass_sigma_m,
            pass_rotation_sigma=arm.pass_rotation_sigma_rad,
            jitter_sigma=arm.jitter_sigma_m,
            outlier_fraction=scan.outliers,
            dropout_burst=setup.faults.dropout_burst or 0.0,
            spurious_m=setup.faults.spurious_m or 0.0,
        ),
        rng,
        coverage=scan.coverage,
        samples=scan.samples,
        depth_buffer=DepthBuffer(cell_m=scan.cell_m, max_incidence_deg=scan.max_incidence_deg),
    )


def _match(
    setup: RegisterTrialSetup, scan: SimulatedScan, shape: MeshModel, targets: np.ndarray
) -> MatchResult:
    """The scan matched to the virtual model as the job's registration settings say: its
    mode, the arm's pass accuracy it is told (per point's pass), its verdict's thresholds.
    Every point of the simulated scan is matched (no voxel thinning, no subsample)."""
    settings = setup.job.localization.registration
    acceptance = Acceptance(
        max_rms=settings.max_rms_m,
        min_inlier_fraction=settings.min_inlier_fraction,
        max_ambiguity=settings.max_ambiguity,
        max_predicted_tre=settings.max_predicted_tre_m,
    )
    passes = None
    if settings.pass_sigma_m is not None:
        passes = ScanPasses(scan.pass_index, settings.pass_sigma_m)
    return match(
        scan.points,
        shape,
        mode=settings.mode,
        targets=targets,
        seed=setup.job.seed,
        acceptance=acceptance,
        passes=passes,
    )


def _row(
    setup: RegisterTrialSetup,
    scanned_name: str,
    scan: SimulatedScan,
    result: MatchResult,
    evaluation: TrialEvaluation,
    names: tuple[str, ...],
    faults: tuple[ScanFaultOutcome, ...],
    t_start: float,
) -> RegisterRow:
    """The trial's row: what was scanned, the match's figures, its errors against the truth
    (per target too), the scan faults' outcomes and the times."""
    target_error_max = float(evaluation.target_error.max())
    predicted = evaluation.predicted_tre
    return RegisterRow(
        case=setup.trial.case,
        model=setup.job.cell.object.model,
        scanned_model=scanned_name,
        n_points=len(scan.points),
        surface_fraction=scan.surface_fraction,
        outlier_fraction=float(1.0 - scan.inlier.mean()),
        verdict=result.verdict,
        reason=result.reason,
        accepted=evaluation.accepted,
        ambiguity=result.ambiguity,
        rms_m=result.rms,
        inlier_fraction=result.inlier_fraction,
        worst_predicted_tre_m=result.worst_predicted_tre,
        rotation_error_rad=evaluation.rotation_error,
        centroid_error_m=evaluation.centroid_error,
        target_error_max_m=target_error_max,
        target_error_mean_m=float(evaluation.target_error.mean()),
        target_error_real_max_m=float(evaluation.target_error_real.max()),
        predicted_tre_max_m=float(predicted.max()),
        right_object=evaluation.right_object,
        good=evaluation.good,
        false_accept=evaluation.false_accept,
        targets=tuple(
            TargetRecord(name, float(error), float(tre), float(ratio))
            for name, error, tre, ratio in zip(
                names, evaluation.target_error, predicted, evaluation.tre_ratio, strict=True
            )
        ),
        faults=faults,
        harmed=evaluation.accepted and target_error_max > HARM_M,
        match_seconds=result.seconds,
        trial_seconds=time.perf_counter() - t_start,
    )


def run_register_trial(config: JsonObject, seed: int) -> RegisterRow:
    """One registration trial of the job configuration `config` (a JobConfig dict, read as
    scenarios.campaign.register_job says) with `seed` (the job's seed); returns its row."""
    t_start = time.perf_counter()
    setup = parse_register_job({**config, "seed": int(seed)})
    model = setup.job.cell.object.model
    rng = np.random.default_rng([setup.job.seed, 0x5CA9])
    virtual, shape = virtual_model(model, setup.trial.model_seed)
    scanned_name = setup.trial.scanned_model or model
    scanned = (
        virtual if scanned_name == model else virtual_model(scanned_name, setup.trial.model_seed)[0]
    )
    real, error = real_model(scanned, model_error(setup.job.cell.noise), setup.job.seed)
    T_table_object = draw_true_pose(setup.job.cell.object.placement, real.mesh.vertices, rng)
    scan = _simulated_scan(setup, real, T_table_object, rng)
    names, targets = targets_of(virtual)
    result = _match(setup, scan, shape, targets)
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
        right_object=scanned_name == model,
        threshold=setup.trial.false_accept_m,
    )
    faults = scan_fault_outcomes(
        setup.faults.names,
        scan.points,
        scan.pass_index,
        shape,
        invert(result.T_model_data),
        result.rms,
        evaluation.accepted,
    )
    return _row(setup, scanned_name, scan, result, evaluation, names, faults, t_start)


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


def scan_fault_outcomes(
    faults: tuple[str, ...],
    points: np.ndarray,
    pass_index: np.ndarray,
    shape: MeshModel,
    T_table_model: np.ndarray,
    rms_m: float,
    accepted: bool,
) -> tuple[ScanFaultOutcome, ...]:
    """Each scan fault's outcome (as the full stage's, scenarios.campaign.full_stage):
    "register" as the stage that saw it (the pass gap for a dropout burst, the points off
    the matched model for spurious returns), recovered if the match was accepted and stopped
    otherwise; missed if not seen."""
    seen = {
        "laser_dropout_burst": lambda: longest_pass_gap(points, pass_index) > 0.0,
        "laser_spurious": lambda: stray_returns(points, shape, T_table_model, rms_m) > 0,
    }
    outcomes = []
    for name in faults:
        if seen[name]():
            outcomes.append(
                ScanFaultOutcome(name, "recovered" if accepted else "stopped", "register")
            )
        else:
            outcomes.append(ScanFaultOutcome(name, "missed", "missed"))
    return tuple(outcomes)
