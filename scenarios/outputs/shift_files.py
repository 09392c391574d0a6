"""A shift's table (shift.csv, a row per job as it ends) and its result (shift.json), each
written completely or not at all."""

from __future__ import annotations

import csv
import io
from dataclasses import asdict
from pathlib import Path

from models.atomic import write_text
from scenarios.outputs.run_folder import write_json
from scenarios.results.shift_result import ShiftJob, ShiftResult


def write_table(path: Path, jobs: tuple[ShiftJob, ...]) -> Path:
    """The jobs as CSV (SI units, empty where a figure is missing)."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(ShiftJob.columns())
    for job in jobs:
        writer.writerow("" if v is None else v for v in asdict(job).values())
    return write_text(path, text.getvalue())


def write_result(path: Path, result: ShiftResult) -> Path:
    """The shift as JSON: its plan, its summary figures and its jobs."""
    data = {
        "job": result.job,
        "robot": result.robot,
        "seed": result.seed,
        "policy": result.policy,
        "jobs_asked": result.jobs_asked,
        "hours": result.hours,
        "summary": {
            "jobs": len(result.jobs),
            "statuses": {s: result.count(s) for s in sorted({j.status for j in result.jobs})},
            "complete_with_a_goal_missed": result.missed_while_complete,
            "mean_cell_time_s": result.mean_cell_time_s,
        },
        "jobs": [asdict(job) for job in result.jobs],
    }
    return write_json(path, data)
