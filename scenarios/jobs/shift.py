"""`twincell shift JOB --jobs N --hours H`: one real cell (the job's seed) through a shift of
jobs, each on a part placed anew (`cell.object.draw`) and with the cell's run-to-run noise
drawn anew (`cell.noise.draw`), while its arm warms and cools (scenarios.jobs.shift_thermal,
the level of `shift.warmup_rad`); what each job does with the calibration is the shift's
`policy` (scenarios.results.shift_result.POLICIES).

The jobs start evenly over the shift's hours (a job that runs past its slot delays the
next). The shift folder holds each job's run folder (jobs/), the table (shift.csv, rewritten
as each job ends, so a shift stopped keeps the jobs it ran), and at the end the result
(shift.json), the figure (shift.png) and the recording (shift.rrd).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path

from scenarios.configuration.config_files import cell_overrides, load_config, with_overrides
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.runner import RunOptions, run_job
from scenarios.jobs.shift_thermal import warm_seconds, warmed
from scenarios.offline.saved_calibration import CALIBRATION_FILE, made_utc
from scenarios.outputs.run_folder import RunFolder
from scenarios.outputs.shift_figure import write_shift_figure
from scenarios.outputs.shift_files import write_result, write_table
from scenarios.outputs.shift_recording import write_shift_recording
from scenarios.results.edge import JsonObject
from scenarios.results.run import RunResult
from scenarios.results.shift_result import ShiftJob, ShiftResult
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]


@dataclass(frozen=True)
class ShiftOptions:
    """Each job's own recording (`rrd`) and the user's cache (`cache`), as `twincell run`
    takes them (the shift itself, its jobs, hours and policy, is the job's `shift` section)."""

    rrd: bool = False
    cache: bool = True


@dataclass(frozen=True)
class _Clock:
    """Where the shift is: its date and time at its start (UTC), its clock since [s], the
    arm's warmth, the calibration the next job is given (None: it calibrates)."""

    start_utc: datetime
    time_s: float = 0.0
    warmth: float = 0.0
    calibration: Path | None = None


def run_shift(
    name: str | Path | JobConfig,
    seed: int | None = None,
    out: str | Path = "runs",
    progress: Progress | None = None,
    overrides: JsonObject | None = None,
    cell: str | Path | None = None,
    options: ShiftOptions | None = None,
) -> tuple[Path, ShiftResult]:
    """Run the shift of job `name` (a shipped job or a YAML, or a job's configuration; with
    `seed`, `overrides` and `cell` as `twincell run` takes them) into a new shift folder
    under `out`; its jobs, hours and policy are the configuration's `shift` section. Returns
    the folder and the shift's result."""
    options = options or ShiftOptions()
    extra = dict(overrides or {}) | ({} if seed is None else {"seed": seed})
    if isinstance(name, JobConfig):
        config: object = name
        if cell is not None:
            config = with_overrides(name, cell_overrides(cell), f"cell {cell}")
        if extra and isinstance(config, JobConfig):
            config = with_overrides(config, extra, "the shift")
    else:
        config = load_config(name, extra, cell)
    if not isinstance(config, JobConfig):
        kind = getattr(config, "kind", type(config).__name__)
        raise ScenarioError(f"a shift runs a cell job; {name!r} is a {kind} job")
    say = progress or (lambda _m: None)
    folder = RunFolder(out, f"{config.name}-shift")
    clock, jobs = _Clock(datetime.now(UTC)), []
    shift = config.shift
    slot_s = shift.hours * 3600.0 / shift.jobs
    try:
        for k in range(shift.jobs):
            job, clock = _run_one(config, k, slot_s, clock, folder.path, options, say)
            jobs.append(job)
            write_table(folder.file("shift.csv"), tuple(jobs))
    finally:
        robot = Path(config.cell.robot.model).stem  # a shipped arm's name, or its file's
        result = ShiftResult(
            config.name, robot, config.seed, shift.policy, shift.jobs, shift.hours, tuple(jobs),
        )  # fmt: skip
        write_result(folder.file("shift.json"), result)
        folder.remove_partial()
    if jobs:
        write_shift_figure(folder.file("shift.png"), result, config.checks.target_error_rms_m)
        write_shift_recording(folder.file("shift.rrd"), result)
    return folder.path, result


def _run_one(
    config: JobConfig,
    k: int,
    slot_s: float,
    clock: _Clock,
    shift: Path,
    options: ShiftOptions,
    say: Progress,
) -> tuple[ShiftJob, _Clock]:
    """Job `k` of the shift: started at its slot (or when the job before ended), the arm
    warmed or cooled to then, the cell's clock the shift's; the last calibration given
    unless the policy calibrates every job or it is older than `calibration.max_age_h` on
    the shift's clock (expired); returns its row and the clock after it."""
    tau_s, policy = config.cell.noise.drives.warmup_tau_s, config.shift.policy
    start_s = max(k * slot_s, clock.time_s)
    warmth = warmed(clock.warmth, start_s - clock.time_s, config.shift.duty, tau_s)
    now = clock.start_utc + timedelta(seconds=start_s)
    given = None if policy == "every" else clock.calibration
    age_h = None if given is None else (now - made_utc(given)).total_seconds() / 3600.0
    expired = age_h is not None and age_h > config.calibration.max_age_h
    if given is not None and expired:
        say(
            f"shift: job {k}: the calibration {given.relative_to(shift)} is {age_h:.2f} h old, "
            f"more than calibration.max_age_h = {config.calibration.max_age_h:g} h: the job "
            "calibrates anew"
        )
        given = None
    overrides: JsonObject = {
        "cell.clock_utc": now.isoformat(),
        "cell.noise.draw": k,
        "cell.object.draw": k,
        "cell.noise.drives.warmup_rad": list(config.shift.warmup_rad),
        "cell.noise.drives.warm_s": warm_seconds(warmth, tau_s),
        "cell.noise.arm_thermal_strain": config.shift.thermal_strain(warmth, start_s / 3600.0),
        "calibration.given": "keep" if policy == "once" else "check",
    }
    run_options = RunOptions(rrd=options.rrd, cache=options.cache, calibration=given)
    job_config = with_overrides(config, overrides, "the shift")  # bad input stops the shift
    jobs_dir = shift / "jobs"
    before = set(jobs_dir.glob("*-*")) if jobs_dir.is_dir() else set()
    t0 = time.perf_counter()
    try:
        path, result = run_job(
            job_config, out=jobs_dir, progress=lambda m: say(f"[job {k}] {m}"),
            options=run_options,
        )  # fmt: skip
    except Exception as exc:  # the job stopped; the shift goes on with the next part
        made = sorted(set(jobs_dir.glob("*-*")) - before) if jobs_dir.is_dir() else []
        path, result = (made[0] if made else jobs_dir), None
        reason = f"{exc}"
    else:
        reason = result.reason if isinstance(result, RunResult) else ""
    wall_s = time.perf_counter() - t0
    row = _row(k, start_s, warmth, config, path, shift, result, reason, wall_s, expired)
    say(_line(row))
    cell_s = row.cell_time_s or 0.0
    kept = path / CALIBRATION_FILE
    calibration = clock.calibration
    if kept.is_file() and (policy == "check" or calibration is None or expired):
        calibration = kept
    after = warmed(warmth, cell_s, 1.0, tau_s)
    return row, replace(clock, time_s=start_s + cell_s, warmth=after, calibration=calibration)


def _row(
    k: int,
    start_s: float,
    warmth: float,
    config: JobConfig,
    path: Path,
    shift: Path,
    result: object,
    reason: str,
    wall_s: float,
    expired: bool = False,
) -> ShiftJob:
    """The table's row of job `k` from its result (None or not a cell job's: it stopped);
    `expired`: the last calibration was too old to be given."""
    warmup_j2_rad = config.shift.warmup_rad[1] * warmth
    strain = config.shift.thermal_strain(warmth, start_s / 3600.0)
    folder = str(path.relative_to(shift)) if path.is_relative_to(shift) else str(path)
    if not isinstance(result, RunResult):
        return ShiftJob(
            k, start_s / 3600.0, warmth, warmup_j2_rad, strain, "incomplete", reason, "failed",
            None, None, None, None, None, None, None, None, None, wall_s, folder,
        )  # fmt: skip
    summary = result.calibration.summary
    check = summary.check if summary is not None else None
    if summary is None or summary.given is None:
        decision = "expired" if expired else "calibrated"
    else:
        decision = "recalibrated" if check is not None and not check.passed else "kept"
    exported = result.exported_program
    ran = exported is not None and exported.status == "complete"
    checks = result.checks
    return ShiftJob(
        k, start_s / 3600.0, warmth, warmup_j2_rad, strain, result.status, reason, decision,
        None if check is None else check.drift_m, None if check is None else check.bound_m,
        None if check is None else check.tolerance_m,
        result.target_error_rms_m, result.target_error_max_m,
        exported.target_error_rms_m if ran and exported else None,
        exported.target_error_max_m if ran and exported else None,
        all(c.met for c in checks.values()) if checks else None,
        result.cell_time_s, wall_s, folder,
    )  # fmt: skip


def _line(job: ShiftJob) -> str:
    """The progress line of a job that ended."""
    mm = "?" if job.target_rms_m is None else f"{job.target_rms_m * 1e3:.3f} mm"
    bound = "" if job.check_bound_m is None else f" (check bound {job.check_bound_m * 1e3:.3f} mm)"
    cell = "?" if job.cell_time_s is None else f"{job.cell_time_s:.0f} s"
    return (
        f"shift: job {job.job} at {job.start_h:.2f} h (warmth {job.warmth:.2f}): {job.status}, "
        f"calibration {job.calibration}{bound}, targets' RMS {mm}, cell time {cell}"
    )
