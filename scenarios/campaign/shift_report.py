"""The report of a shift campaign (`twincell campaign JOB --stage shift`), from its results
table alone: per sweep point (a policy, say) and over all shifts, how the jobs ended, what
they did with the calibration, the jobs that ended complete with a goal missed, the targets'
RMS of the jobs' own runs and of their exported programs over every job (the twin's truth),
and the mean cell time per job; one figure of the targets' RMS and the cell time per
group."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from models.atomic import write_text
from scenarios.campaign.plots import save_png
from scenarios.campaign.rows import group_rows, json_ready, per_target, quantiles
from scenarios.campaign.shift_stage import DECISIONS, STATUSES

Rows = list[dict[str, str]]

SHIFT_NOTE = (
    "Stage: shift. Each trial runs one real cell (its seed) through a shift of jobs "
    "(`shift.jobs` over `shift.hours`), each on a part placed anew while the arm warms and "
    "cools, doing with the calibration what `shift.policy` says. A trial's seed is the same "
    "cell at every sweep point."
)


@dataclass(frozen=True)
class ShiftSummary:
    """A group of shift trials: how many (failed: a user error; crashed: a bug), the jobs
    they ran, per status and per calibration decision, the jobs complete with a goal missed,
    quantiles over every job of its own run's targets' RMS and its exported program's [m],
    the mean cell time per job [s] and the trials' wall time [s]."""

    label: str
    shifts: int
    errors: int
    crashes: int
    jobs: int
    statuses: dict[str, int]
    decisions: dict[str, int]
    missed_while_complete: int
    job_rms: dict[str, float]
    exported_rms: dict[str, float]
    mean_cell_time_s: float
    trial_seconds: dict[str, float]


def _count(rows: Rows, column: str) -> int:
    return sum(int(float(r[column])) for r in rows if r.get(column, "") not in ("", None))


def summarize_shifts(rows: Rows, label: str) -> ShiftSummary:
    """Aggregate the rows (strings, as read from the CSV) of one group."""
    ok = [r for r in rows if r.get("status") == "ok"]
    times = per_target(ok, "cell_time_j", "_s")
    seconds = [float(r["trial_seconds"]) for r in rows if r.get("trial_seconds", "") != ""]
    return ShiftSummary(
        label=label,
        shifts=len(rows),
        errors=sum(r.get("status") == "error" for r in rows),
        crashes=sum(r.get("status") == "crash" for r in rows),
        jobs=_count(ok, "jobs"),
        statuses={s: _count(ok, f"jobs_{s}") for s in STATUSES},
        decisions={d: _count(ok, f"calibration_{d}") for d in DECISIONS},
        missed_while_complete=_count(ok, "missed_while_complete"),
        job_rms=quantiles(per_target(ok, "job_rms_j", "_m")),
        exported_rms=quantiles(per_target(ok, "exported_rms_j", "_m")),
        mean_cell_time_s=float(np.mean(times)) if len(times) else math.nan,
        trial_seconds=quantiles(np.array(seconds, dtype=float)),
    )


def shift_summaries(rows: Rows, keys: list[str]) -> list[ShiftSummary]:
    """One summary per sweep point and the last one over all trials."""
    groups = [summarize_shifts(group, label) for label, group in group_rows(rows, keys)]
    return [*(groups if keys else []), summarize_shifts(rows, "all")]


def _mm(q: dict[str, float]) -> str:
    return " / ".join(
        "-" if math.isnan(q[k]) else f"{q[k] * 1e3:.3f}" for k in ("median", "q95", "max")
    )


def _counts(counts: dict[str, int]) -> str:
    return ", ".join(f"{n} {name}" for name, n in counts.items() if n) or "-"


def shift_markdown(summaries: list[ShiftSummary]) -> str:
    """The report as Markdown: the stage note, the totals, one table row per group."""
    total = summaries[-1]
    lines = [
        "# Campaign report",
        "",
        SHIFT_NOTE,
        "",
        f"- shifts: {total.shifts} ({total.errors} failed, {total.crashes} crashed), "
        f"{total.jobs} jobs",
        f"- jobs that ended complete with a goal missed: {total.missed_while_complete} (goal 0)",
        "",
        "| group | shifts | jobs | statuses | calibration | complete, goal missed | "
        "job's own RMS median / q95 / max [mm] | exported RMS median / q95 / max [mm] | "
        "mean cell time per job [s] | trial time median [s] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summaries:
        cell = "-" if math.isnan(s.mean_cell_time_s) else f"{s.mean_cell_time_s:.0f}"
        wall = s.trial_seconds["median"]
        lines.append(
            f"| {s.label} | {s.shifts} | {s.jobs} | {_counts(s.statuses)} | "
            f"{_counts(s.decisions)} | {s.missed_while_complete} | {_mm(s.job_rms)} | "
            f"{_mm(s.exported_rms)} | {cell} | {'-' if math.isnan(wall) else f'{wall:.0f}'} |"
        )
    return "\n".join(lines) + "\n"


def write_shift_report(folder: Path, rows: Rows, keys: list[str]) -> list[Path]:
    """Write report.md, report.json and shift_policies.png of a shift campaign in `folder`."""
    summaries = shift_summaries(rows, keys)
    data = {"stage": "shift", "note": SHIFT_NOTE, "groups": [asdict(s) for s in summaries]}
    return [
        write_text(folder / "report.md", shift_markdown(summaries)),
        write_text(folder / "report.json", json.dumps(json_ready(data), indent=2)),
        _figure(folder / "shift_policies.png", rows, keys),
    ]


def _figure(path: Path, rows: Rows, keys: list[str]) -> Path:
    """Per group: box plots of every job's targets' RMS, of its own run and of its exported
    program (where one ran), against the job's RMS goal; and the mean cell time per job."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    groups = group_rows(ok, keys) if keys else [("all", ok)]
    labels = [label.replace(", ", "\n") for label, _ in groups]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for prefix, side, color, name in (
        ("job_rms_j", -0.18, "tab:blue", "the job's own run"),
        ("exported_rms_j", 0.18, "tab:orange", "its exported program"),
    ):
        values = [per_target(g, prefix, "_m") * 1e3 for _, g in groups]
        at = [k + side for k, v in enumerate(values) if np.isfinite(v).any()]
        if at:
            shown = [v[np.isfinite(v)] for v in values if np.isfinite(v).any()]
            box = left.boxplot(
                shown, positions=at, widths=0.3, whis=(5, 95), patch_artist=True,
                medianprops={"color": "black"},
            )  # fmt: skip
            for patch in box["boxes"]:
                patch.set_facecolor(color)
            left.plot([], [], "s", color=color, label=name)
    goals = {float(r["goal_rms_m"]) for r in ok if r.get("goal_rms_m", "") not in ("", None)}
    for goal in goals:
        left.axhline(goal * 1e3, color="red", lw=1, ls="--", label="RMS goal")
    left.set_xticks(range(len(labels)), labels)
    left.set_ylabel("targets' RMS per job [mm]")
    left.set_title("every job's targets (truth; whiskers q05-q95)")
    left.legend(fontsize=8)
    times = [per_target(g, "cell_time_j", "_s") for _, g in groups]
    means = [float(np.mean(t)) if len(t) else 0.0 for t in times]
    right.bar(range(len(labels)), means, color="tab:blue")
    right.set_xticks(range(len(labels)), labels)
    right.set_ylabel("mean cell time per job [s]")
    right.set_title("cell time per job")
    for k, mean in enumerate(means):
        right.annotate(f"{mean:.0f} s", (k, mean), ha="center", va="bottom")
    fig.tight_layout()
    return save_png(fig, path)
