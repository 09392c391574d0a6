"""The full stage as a campaign trial: the whole scenario (scan in the simulated cell, match,
corrected program executed in physics, evaluation) run headless by `scenarios.runner.run_job`
into a temporary run folder; its results become one flat row.

Target errors: `err_t<k>_m` is the registration's share of target k's error (the virtual
target moved by the estimated pose against the true one), comparable with the predicted TRE;
`exec_err_t<k>_m` is the achieved tool tip against the true target (arm included).
`job_rms_m`, `job_max_m`: the job's own execution's target errors; `exported_rms_m`,
`exported_max_m`: those of the exported program run by a controller without absolute
accuracy at the end of the job (`exported_status`, `exported_compensation`). The scan's
plan: `scan_plan` (its mode), `scan_passes`, `scan_time_s` (cell time of the scan motions),
`scan_through_home` (passes reached through home) and the planner's predictions
(`scan_predicted_time_s`, `scan_predicted_tre_max_m`, `plan_tre_t<k>_m`).
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass
from typing import Any

from cattrs.gen import override

from scenarios.campaign.register_trial import MAX_TARGETS
from scenarios.campaign.rows import HARM_M
from scenarios.results.edge import JsonObject
from scenarios.results.exported_result import ExportedRun
from scenarios.results.json_converter import register_writer
from scenarios.results.results_file import read_results
from scenarios.results.run import RAN, RunResult
from scenarios.results.scan_plan_result import ScanPlanSummary

#: A good match: every target within this of the truth [m], the registration's share and the
#: achieved tip; a run with no target reached, its pose within GOOD_M and GOOD_DEG [deg] (a
#: degree moves a point 0.1 m from the origin by 1.7 mm).
GOOD_M = 2.0e-3
GOOD_DEG = 1.0


def _number(value: float | None) -> float:
    return float("nan") if value is None else float(value)


@dataclass(frozen=True)
class FullTarget:
    """One target of a full trial: its name, the registration's share of its error (the
    virtual target moved by the estimated pose against the true one) and the achieved tool
    tip's error [m], and the match's predicted TRE there [m] (NaN: none)."""

    name: str
    registration_error_m: float
    executed_error_m: float
    predicted_tre_m: float

    @property
    def ratio(self) -> float:
        """Registration error over predicted TRE (NaN where nothing was predicted)."""
        if self.predicted_tre_m > 0:
            return self.registration_error_m / self.predicted_tre_m
        return float("nan")


@dataclass(frozen=True, eq=False)
class FullRow:
    """The row of one full trial: the run's result (scenarios.results.run.RunResult, as its
    results.json holds it) and the trial's wall time [s]; the results' converter flattens it
    to the results table's columns, in the table's order (`full_row`, then trial_seconds)."""

    result: RunResult
    trial_seconds: float

    @property
    def targets(self) -> tuple[FullTarget, ...]:
        primary = self.result.primary
        return tuple(
            FullTarget(
                t.name, t.registration_error_m, t.error_m, _number(primary.predicted(t.name))
            )
            for t in self.result.targets[:MAX_TARGETS]
        )


def headless_config(config: JsonObject, seed: int) -> Any:
    """The trial's configuration (scenarios.configuration): `config` (a config dict) with
    `seed`, without recording or figures."""
    from scenarios.configuration.config_files import parse_config

    data = {**config, "seed": int(seed)}
    if "output" in data:
        data["output"] = {**data["output"], "rrd": False, "plots": False}
    return parse_config(data, "campaign trial")


def run_full_trial(config: JsonObject, seed: int) -> FullRow:
    """Run the scenario `config` (a scenario config dict) with `seed`, without recording or
    figures; its row, from the run's results.json read back."""
    from scenarios.jobs.runner import RunOptions, run_job

    t0 = time.perf_counter()
    scenario = headless_config(config, seed)
    with tempfile.TemporaryDirectory(prefix="twincell-trial-") as tmp:
        folder, _ = run_job(scenario, out=tmp, options=RunOptions(rrd=False, spawn=False))
        result = read_results(folder)
    return FullRow(result, time.perf_counter() - t0)


def full_row(result: RunResult, targets: tuple[FullTarget, ...]) -> JsonObject:
    """The columns of a run's result: the match, the errors at the `targets` (the
    registration's share and the achieved), the exported program's, the scan plan's, the
    faults', the timings ([m], [rad], [s])."""
    match = result.match
    reg_errors = [t.registration_error_m for t in targets]
    exec_errors = [t.executed_error_m for t in targets]
    within = bool(reg_errors) and max(reg_errors + exec_errors) <= GOOD_M
    accepted = match is not None and match.verdict == "accepted"
    surface = result.method("surface")
    pose = None if surface is None else surface.pose
    # A run stopped before its targets (refused by a later check, aborted) has no target
    # error: its accepted match is judged by the pose itself.
    wrong_pose = pose is not None and (
        pose.translation_error_m > GOOD_M or pose.rotation_error_deg > GOOD_DEG
    )
    reason = result.reason if match is None else match.reason
    if match is None and surface is not None and not surface.accepted:
        reason = surface.reason
    row: JsonObject = {
        "job": result.job,
        "model": result.model,
        "run_status": result.status,
        "n_points": result.scan_points,
        "verdict": "rejected" if match is None else match.verdict,
        "reason": reason,
        "accepted": int(accepted),
        "ambiguity": None if match is None else match.ambiguity,
        "rms_m": None if match is None else match.rms_m,
        "inlier_fraction": None if match is None else match.inlier_fraction,
        "rotation_error_rad": None if pose is None else math.radians(pose.rotation_error_deg),
        "translation_error_m": None if pose is None else pose.translation_error_m,
        "target_error_max_m": max(reg_errors) if reg_errors else None,
        "executed_error_max_m": max(exec_errors) if exec_errors else None,
        "right_object": 1,
        "good": int(within),
        "false_accept": int(accepted and (not within if reg_errors else wrong_pose)),
        "n_targets": len(targets),
        "job_rms_m": result.target_error_rms_m,
        "job_max_m": result.target_error_max_m,
        "targets": ";".join(t.name for t in targets),
    }
    for k, target in enumerate(targets):
        row[f"err_t{k}_m"] = target.registration_error_m
        row[f"exec_err_t{k}_m"] = target.executed_error_m
        row[f"tre_t{k}_m"] = target.predicted_tre_m
        row[f"ratio_t{k}"] = target.ratio
    row.update(budget_columns(result, targets))
    row.update(_exported_columns(result.exported_program))
    row["stage"] = result.stage or ""
    row.update(_plan_columns(result.scan_plan))
    row.update(fault_columns(result))
    row.update(verify_columns(result))
    row["cell_time_s"] = result.cell_time_s
    for stage, seconds in result.timings.items():
        row[f"{stage}_seconds"] = seconds
    return row


def budget_columns(result: RunResult, targets: tuple[FullTarget, ...]) -> JsonObject:
    """The error budget's columns (empty without one): its RMS and largest bounds [m],
    whether the goals were within reach, and at each of the `targets` its standard error
    `budget_sigma_t{k}_m` [m] (bench/budget_coverage.py calibrates the coverage factors on
    them)."""
    budget = result.budget
    if budget is None:
        return {}
    sigma = {t.name: t.sigma_m for t in budget.targets}
    row: JsonObject = {
        "budget_rms_bound_m": budget.rms_bound_m,
        "budget_max_bound_m": budget.max_bound_m,
        "budget_within_reach": int(budget.within_reach),
    }
    for k, target in enumerate(targets):
        row[f"budget_sigma_t{k}_m"] = sigma.get(target.name)
    return row


def _exported_columns(exported: ExportedRun | None) -> JsonObject:
    if exported is None:
        return {"exported_status": "none", "exported_compensation": "",
                "exported_rms_m": None, "exported_max_m": None}  # fmt: skip
    return {
        "exported_status": exported.status,
        "exported_compensation": exported.compensation,
        "exported_rms_m": exported.target_error_rms_m,
        "exported_max_m": exported.target_error_max_m,
    }


def _plan_columns(plan: ScanPlanSummary | None) -> JsonObject:
    if plan is None:
        return {"scan_plan": "", "scan_passes": None, "scan_time_s": None,
                "scan_through_home": 0, "scan_predicted_time_s": None,
                "scan_predicted_tre_max_m": None}  # fmt: skip
    row: JsonObject = {
        "scan_plan": plan.mode,
        "scan_passes": plan.passes,
        "scan_time_s": plan.scan_time_s,
        "scan_through_home": plan.through_home,
        "scan_predicted_time_s": plan.predicted_scan_time_s,
        "scan_predicted_tre_max_m": plan.predicted_tre_max_m,
    }
    for k, tre in enumerate(plan.predicted_tre_m[:MAX_TARGETS]):
        row[f"plan_tre_t{k}_m"] = tre
    return row


def verify_columns(result: RunResult) -> JsonObject:
    """The checks' columns. The verification's, of its first run (before any re-scan it caused):
    `verify_runs` how often it ran, `verify_agrees`, `verify_resolved`, `verify_strips`,
    `verify_scan_time_s` [s], and over the targets the largest move measured, the largest
    bound and the smallest allowance [m] (empty without a verification); of the tools' checks
    at the beam, the first one's offset and tolerance [m] and how many were made."""
    tools: JsonObject = {}
    if result.tool_checks:
        tools = {
            "tool_off_m": result.tool_checks[0].off_m,
            "tool_checks": len(result.tool_checks),
            "tool_tolerance_m": result.tool_checks[0].tolerance_m,
        }
    if not result.verifications:
        return {"verify_runs": 0} | tools
    first = result.verifications[0]
    checks = first.checks
    return {
        "verify_runs": len(result.verifications),
        "verify_agrees": int(first.agrees),
        "verify_resolved": int(first.resolved),
        "verify_strips": len(first.strips),
        "verify_scan_time_s": first.scan_time_s,
        "verify_moved_max_m": max((c.moved_m for c in checks), default=None),
        "verify_uncertainty_max_m": max((c.uncertainty_m for c in checks), default=None),
        "verify_allowance_min_m": min((c.allowance_m for c in checks), default=None),
    } | tools


def fault_columns(result: RunResult) -> JsonObject:
    """The row's fault columns: for each fault injected, `fault.<name>` its outcome
    ("recovered": detected and the run complete; "stopped": detected and the run aborted
    or refused; "missed": not detected; "not injected": its occasion never came) and
    `fault.<name>.stage` the stage that detected it; `harmed` 1 if the run is complete with
    a target error beyond HARM_M."""
    out: JsonObject = {}
    for fault in result.faults:
        if not fault.detected:
            outcome = fault.detected_by
        else:
            outcome = "recovered" if result.status in RAN else "stopped"
        out[f"fault.{fault.name}"] = outcome
        out[f"fault.{fault.name}.stage"] = fault.detected_by
        if fault.target_move_m is not None:
            out[f"fault.{fault.name}.target_move_m"] = fault.target_move_m
    worst = result.target_error_max_m
    out["harmed"] = int(result.status in RAN and worst is not None and worst > HARM_M)
    return out


register_writer(
    FullRow,
    keys="... trial_seconds",
    derived=lambda r: full_row(r.result, r.targets),
    result=override(omit=True),
)
