"""The shift stage as a campaign trial: one real cell (the trial's seed) through a shift of
jobs (scenarios.jobs.shift.run_shift: `shift.jobs` over `shift.hours` of the cell's clock,
each doing with the calibration what `shift.policy` says), headless, into a temporary
folder; its jobs become one flat row. Sweeping `shift.policy` compares the policies on the
same cells (a trial's seed is the same at every sweep point).

Columns: the shift's policy, jobs and hours; how many jobs ended with each status
(`jobs_<status>`) and did what with the calibration (`calibration_<decision>`); the jobs that
ended complete with a goal missed (`missed_while_complete`); the mean cell time per job [s];
and per job k (truth, the twin's measure): `job_rms_j<k>_m` (its own run's targets' RMS),
`exported_rms_j<k>_m` (its exported program's), `cell_time_j<k>_s` and the check's 95 %
bound `check_bound_j<k>_m` (empty where a job has none).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass

from cattrs.gen import override

from scenarios.results.edge import JsonObject
from scenarios.results.json_converter import register_writer
from scenarios.results.shift_result import ShiftResult

#: The statuses and calibration decisions a row counts (a job's status is one of the run's;
#: its decision one of ShiftJob.calibration's).
STATUSES = ("complete", "at_risk", "refused", "aborted", "incomplete")
DECISIONS = ("calibrated", "kept", "recalibrated", "expired", "failed")

#: Per job k: the row's column and the ShiftJob field it holds.
PER_JOB = (
    ("job_rms_j{k}_m", "target_rms_m"),
    ("exported_rms_j{k}_m", "exported_rms_m"),
    ("cell_time_j{k}_s", "cell_time_s"),
    ("check_bound_j{k}_m", "check_bound_m"),
)


@dataclass(frozen=True, eq=False)
class ShiftRow:
    """The row of one shift trial: the shift's result, the trial's wall time [s] and its
    job's RMS goal [m] (None: none); the results' converter flattens it to the table's
    columns (`shift_row`, then trial_seconds and goal_rms_m)."""

    result: ShiftResult
    trial_seconds: float
    goal_rms_m: float | None = None


def run_shift_trial(config: JsonObject, seed: int) -> ShiftRow:
    """Run the shift of the job `config` (a job configuration dict) on the cell `seed`,
    without the jobs' recordings; its row."""
    from scenarios.campaign.full_stage import headless_config
    from scenarios.configuration.job_config import JobConfig
    from scenarios.jobs.shift import ShiftOptions, run_shift
    from scenarios.scenario_errors import ScenarioError

    t0 = time.perf_counter()
    job = headless_config(config, seed)
    if not isinstance(job, JobConfig):
        raise ScenarioError(f"the shift stage runs a cell job; this trial's is a {job.kind} job")
    with tempfile.TemporaryDirectory(prefix="twincell-shift-") as tmp:
        _, result = run_shift(job, out=tmp, options=ShiftOptions(rrd=False))
    return ShiftRow(result, time.perf_counter() - t0, job.checks.target_error_rms_m)


def shift_row(result: ShiftResult) -> JsonObject:
    """The columns of a shift's result (see the module's docstring) [m], [s]."""
    jobs = result.jobs
    row: JsonObject = {
        "job": result.job,
        "robot": result.robot,
        "policy": result.policy,
        "jobs": len(jobs),
        "jobs_asked": result.jobs_asked,
        "hours": result.hours,
        "missed_while_complete": result.missed_while_complete,
        "mean_cell_time_s": result.mean_cell_time_s,
    }
    row |= {f"jobs_{s}": sum(j.status == s for j in jobs) for s in STATUSES}
    row |= {f"calibration_{d}": sum(j.calibration == d for j in jobs) for d in DECISIONS}
    for k, job in enumerate(jobs):
        for column, name in PER_JOB:
            row[column.format(k=k)] = getattr(job, name)
    return row


register_writer(
    ShiftRow,
    keys="... trial_seconds goal_rms_m",
    derived=lambda r: shift_row(r.result),
    result=override(omit=True),
)
