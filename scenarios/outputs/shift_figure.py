"""The shift's figure (shift.png): over the shift's hours, each job's target errors against
its goal, the arm's warm-up drift (truth) and what the quick check measured, and each job's
cell time by what it did with the calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from models.atomic import write_atomic
from scenarios.results.shift_result import ShiftResult

#: The bars' colour by what a job did with the calibration.
COLOURS = {
    "calibrated": "tab:blue",
    "kept": "tab:green",
    "recalibrated": "tab:orange",
    "expired": "tab:purple",
    "failed": "tab:red",
}


def write_shift_figure(path: Path, result: ShiftResult, goal_rms_m: float | None) -> Path:
    """Three panels over the shift's hours; written through a temporary file."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    jobs = result.jobs
    hours = result.column("start_h")
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    fig.subplots_adjust(hspace=0.3)
    ax = axes[0]
    ax.plot(hours, result.column("target_rms_m", 1e3), "o-", label="targets' RMS, the job's")
    ax.plot(hours, result.column("exported_rms_m", 1e3), "s--", label="exported program's")
    ax.plot(hours, result.column("target_max_m", 1e3), "^:", label="largest target error")
    if goal_rms_m is not None:
        ax.axhline(goal_rms_m * 1e3, color="red", lw=1, ls="--", label="RMS goal")
    ax.set_ylabel("target error [mm]")
    ax.legend(fontsize=8)
    ax.set_title(f"{result.job} on the {result.robot}, seed {result.seed}: policy {result.policy}")
    ax = axes[1]
    ax.plot(hours, result.column("warmup_j2_rad", 1e3), "o-", color="tab:red",
            label="joint 2's warm-up shift at the job's start (truth)")  # fmt: skip
    ax.set_ylabel("warm-up shift [mrad]")
    twin = ax.twinx()
    up = result.column("check_bound_m", 1e3) - result.column("check_drift_m", 1e3)
    label = "check: spheres' drift, to its 95 % bound"
    drift = result.column("check_drift_m", 1e3)
    twin.errorbar(
        hours, drift, yerr=[np.zeros_like(up), up], fmt="D", color="tab:purple", label=label
    )
    tolerance = result.column("check_tolerance_m", 1e3)
    if np.isfinite(tolerance).any():
        twin.plot(hours, tolerance, "_", color="tab:purple", ms=14, label="check's tolerance")
    twin.set_ylabel("checked drift [mm]")
    ax.set_ylim(bottom=0.0)
    twin.set_ylim(bottom=0.0)
    lines = ax.get_legend_handles_labels(), twin.get_legend_handles_labels()
    ax.legend(lines[0][0] + lines[1][0], lines[0][1] + lines[1][1], fontsize=7, ncol=2,
              loc="lower left", bbox_to_anchor=(0.0, 1.0), frameon=False)  # fmt: skip
    ax = axes[2]
    width = 0.6 * (hours[1] - hours[0]) if len(hours) > 1 else 0.2
    for kind, colour in COLOURS.items():
        pick = [i for i, j in enumerate(jobs) if j.calibration == kind]
        if not pick:
            continue
        times = [jobs[i].cell_time_s or 0.0 for i in pick]
        ax.bar(hours[pick], times, width=width, color=colour, label=kind)
    ax.set_ylabel("cell time [s]")
    ax.set_xlabel("shift time at the job's start [h]")
    ax.legend(fontsize=8)
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png"))
    finally:
        plt.close(fig)
    return path
