"""Calibration policies over shifts on the same cells: every job calibrating (as a single
`twincell run` does), calibrating once, and the check-driven policy.

    python bench/bench_shift.py [--job skull] [--seeds 1000 1001 ...] [--jobs 12]
        [--hours 4] [--policies check once every] [--workers 2] [--out DIR]

Each seed is one real cell; each policy runs the same shift on it (`twincell shift JOB
--seed S --jobs N --hours H --policy P`: the same parts placed alike, the same noise, the arm
warming alike while the jobs' cell times agree). Prints per policy: the jobs' statuses and
what they did with the calibration, the jobs that ended complete with a goal missed, the
targets' RMS of each job's run and of its exported program (median, q95, largest; the twin's
truth), and the mean cell time per job against `every`'s. The shifts' folders are kept under
--out.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from scenarios.jobs.shift import run_shift
from scenarios.results.shift_result import POLICIES, ShiftJob, ShiftResult


def _shift(job: str, seed: int, policy: str, jobs: int, hours: float, out: str) -> ShiftResult:
    shift = {"shift.jobs": jobs, "shift.hours": hours, "shift.policy": policy}
    _, result = run_shift(job, seed, Path(out) / f"{policy}-{seed}", overrides=shift)
    print(f"  seed {seed}, policy {policy}: {len(result.jobs)} jobs", file=sys.stderr, flush=True)
    return result


def _q(values: list[float], q: float) -> str:
    return f"{np.percentile(values, q) * 1e3:.3f}" if values else "-"


def _row(policy: str, shifts: list[ShiftResult], every_s: float | None) -> list[str]:
    jobs: list[ShiftJob] = [j for s in shifts for j in s.jobs]
    statuses = sorted({j.status for j in jobs})
    decisions = sorted({j.calibration for j in jobs})
    own = [j.target_rms_m for j in jobs if j.target_rms_m is not None]
    exported = [j.exported_rms_m for j in jobs if j.exported_rms_m is not None]
    times = [j.cell_time_s for j in jobs if j.cell_time_s is not None]
    mean_s = float(np.mean(times)) if times else None
    ratio = f"{mean_s / every_s:.2f}" if mean_s is not None and every_s else "-"
    return [
        policy,
        str(len(shifts)),
        str(len(jobs)),
        ", ".join(f"{sum(j.status == s for j in jobs)} {s}" for s in statuses),
        ", ".join(f"{sum(j.calibration == d for j in jobs)} {d}" for d in decisions),
        str(sum(s.missed_while_complete for s in shifts)),
        f"{_q(own, 50)} / {_q(own, 95)} / {_q(own, 100)}",
        f"{_q(exported, 50)} / {_q(exported, 95)} / {_q(exported, 100)}",
        "-" if mean_s is None else f"{mean_s:.0f}",
        ratio,
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", default="skull")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1000, 1001, 1002, 1003, 1004])
    parser.add_argument("--jobs", type=int, default=12)
    parser.add_argument("--hours", type=float, default=4.0)
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None, help="keep the shifts' folders here")
    args = parser.parse_args()
    out = args.out or tempfile.mkdtemp(prefix="bench_shift-")
    plan = [(p, s) for p in args.policies for s in args.seeds]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = {
            (p, s): pool.submit(_shift, args.job, s, p, args.jobs, args.hours, out) for p, s in plan
        }
        results = {key: f.result() for key, f in futures.items()}
    by_policy = {p: [results[(p, s)] for s in args.seeds] for p in args.policies}
    every = [j.cell_time_s for s in by_policy.get("every", []) for j in s.jobs if j.cell_time_s]
    every_s = float(np.mean(every)) if every else None
    table = Table(
        title=f"{args.job}: {len(args.seeds)} cells (seeds {args.seeds[0]}..{args.seeds[-1]}), "
        f"{args.jobs} jobs over {args.hours:g} h each"
    )
    for column in ("policy", "shifts", "jobs", "statuses", "calibration",
                   "complete, goal missed", "targets' RMS [mm] q50 / q95 / max",
                   "exported RMS [mm] q50 / q95 / max", "cell time per job [s]",
                   "/ every's"):  # fmt: skip
        table.add_column(column)
    for policy, shifts in by_policy.items():
        table.add_row(*_row(policy, shifts, every_s))
    Console(width=200).print(table)
    print(f"shift folders: {out}")


if __name__ == "__main__":
    main()
