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
from typing import Any

from scenarios.campaign.register_stage import MAX_TARGETS
from scenarios.campaign.rows import HARM_M


def _number(value: Any) -> float:
    return float("nan") if value is None else float(value)


def run_full_trial(config: dict[str, Any], seed: int) -> dict[str, Any]:
    """Run the scenario `config` (a scenario config dict) with `seed`, without recording or
    figures; returns the flat metrics of the row ([m], [rad], [s])."""
    from scenarios.jobs.config import parse_config
    from scenarios.jobs.runner import RunOptions, run_job

    t0 = time.perf_counter()
    data = {**config, "seed": int(seed)}
    if "output" in data:
        data["output"] = {**data["output"], "rrd": False, "plots": False}
    scenario = parse_config(data, "campaign trial")
    with tempfile.TemporaryDirectory(prefix="twincell-trial-") as tmp:
        _, results = run_job(scenario, out=tmp, options=RunOptions(rrd=False, spawn=False))
    registration = results.get("registration") or {}
    targets = list(results.get("targets") or [])[:MAX_TARGETS]
    verdict = registration.get("verdict") or "rejected"
    reg_errors = [_number(t.get("registration_error_m", t.get("error_m"))) for t in targets]
    exec_errors = [_number(t.get("error_m")) for t in targets]
    threshold = 2.0e-3
    within = bool(reg_errors) and max(reg_errors + exec_errors) <= threshold
    accepted = verdict == "accepted"
    rotation_deg = registration.get("rotation_error_deg")
    row: dict[str, Any] = {
        "job": results.get("job"),
        "model": results.get("model"),
        "run_status": results.get("status"),
        "n_points": results.get("scan_points"),
        "verdict": verdict,
        "reason": registration.get("reason", results.get("reason", "")),
        "accepted": int(accepted),
        "ambiguity": registration.get("ambiguity"),
        "rms_m": registration.get("rms_m"),
        "inlier_fraction": registration.get("inlier_fraction"),
        "rotation_error_rad": None if rotation_deg is None else math.radians(float(rotation_deg)),
        "translation_error_m": registration.get("translation_error_m"),
        "target_error_max_m": max(reg_errors) if reg_errors else None,
        "executed_error_max_m": max(exec_errors) if exec_errors else None,
        "right_object": 1,
        "good": int(within),
        # A run stopped before its targets (aborted) accepted nothing that moved a tool.
        "false_accept": int(accepted and bool(reg_errors) and not within),
        "n_targets": len(targets),
        "job_rms_m": results.get("target_error_rms_m"),
        "job_max_m": results.get("target_error_max_m"),
        "targets": ";".join(str(t.get("name")) for t in targets),
    }
    for k, target in enumerate(targets):
        predicted = _number(target.get("predicted_tre_m"))
        row[f"err_t{k}_m"] = reg_errors[k]
        row[f"exec_err_t{k}_m"] = exec_errors[k]
        row[f"tre_t{k}_m"] = predicted
        row[f"ratio_t{k}"] = reg_errors[k] / predicted if predicted > 0 else float("nan")
    exported = results.get("exported_program") or {}
    row["exported_status"] = exported.get("status", "none")
    row["exported_compensation"] = exported.get("compensation", "")
    row["exported_rms_m"] = exported.get("target_error_rms_m")
    row["exported_max_m"] = exported.get("target_error_max_m")
    row["stage"] = results.get("stage") or ""
    plan = results.get("scan_plan") or {}
    row["scan_plan"] = plan.get("mode", "")
    row["scan_passes"] = plan.get("passes")
    row["scan_time_s"] = plan.get("scan_time_s")
    row["scan_through_home"] = sum(bool(c.get("through_home")) for c in plan.get("chosen") or [])
    row["scan_predicted_time_s"] = plan.get("predicted_scan_time_s")
    row["scan_predicted_tre_max_m"] = plan.get("predicted_tre_max_m")
    for k, tre in enumerate((plan.get("predicted_tre_m") or [])[:MAX_TARGETS]):
        row[f"plan_tre_t{k}_m"] = tre
    row.update(fault_columns(results))
    for stage, seconds in (results.get("timings_s") or {}).items():
        row[f"{stage}_seconds"] = seconds
    row["trial_seconds"] = time.perf_counter() - t0
    return row


def fault_columns(results: dict[str, Any]) -> dict[str, Any]:
    """The row's fault columns: for each fault injected, `fault.<name>` its outcome
    ("recovered": detected and the run complete; "stopped": detected and the run aborted
    or refused; "missed": not detected; "not injected": its occasion never came) and
    `fault.<name>.stage` the stage that detected it; `harmed` 1 if the run is complete with
    a target error beyond HARM_M."""
    out: dict[str, Any] = {}
    status = results.get("status")
    for fault in results.get("faults") or []:
        by = fault.get("detected_by")
        if by in ("missed", "not injected"):
            outcome = by
        else:
            outcome = "recovered" if status == "complete" else "stopped"
        out[f"fault.{fault['name']}"] = outcome
        out[f"fault.{fault['name']}.stage"] = by
    worst = results.get("target_error_max_m")
    out["harmed"] = int(status == "complete" and worst is not None and worst > HARM_M)
    return out
