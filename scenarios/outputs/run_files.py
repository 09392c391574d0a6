"""Files of a run folder besides results.json: scan.ply, program.mod and the PNG plots.
Every file is written to a temporary name and renamed into place (complete or absent)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell import Kinematics, nominal_kinematics
from models.atomic import write_atomic
from models.model import ObjectModel
from scenarios.offline.scan_plan import ScanPlan
from scenarios.outputs.registration_figure import TargetMark, write_registration_figure
from scenarios.outputs.scan_plan_figure import write_scan_plan_figure
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.writer import Filter, program_module

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from registration import MatchResult
    from scenarios.results.run import RunResult


def write_ply(path: Path, points: np.ndarray) -> Path:
    """Points (N, 3) [m] as a binary little-endian PLY point cloud (float64 x, y, z)."""
    p = np.ascontiguousarray(np.asarray(points, dtype="<f8").reshape(-1, 3))
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment units m, nominal table frame\n"
        f"element vertex {len(p)}\nproperty double x\nproperty double y\nproperty double z\n"
        "end_header\n"
    ).encode()

    def write(tmp: Path) -> None:
        tmp.write_bytes(header + p.tobytes())

    return write_atomic(path, write)


def read_ply(path: Path) -> np.ndarray:
    """Points (N, 3) of a PLY written by `write_ply`."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    return np.frombuffer(data[end:], dtype="<f8").reshape(-1, 3)


def write_program(
    path: Path,
    program: OfflineProgram,
    T_table_nominal: np.ndarray,
    kinematics: Kinematics | None = None,
    filtered: Filter | None = None,
) -> Path:
    """The RAPID module of `program` for a controller computing with the arm `kinematics`
    (default: the built-in arm's nominal), filtered for the calibrated arm if `filtered`
    (see scenarios.rapid.writer)."""
    kin = nominal_kinematics() if kinematics is None else kinematics
    text = program_module(program, kin, T_table_nominal, filtered=filtered)
    return write_atomic(path, lambda tmp: tmp.write_text(text))


def write_figures(
    folder: Path,
    result: RunResult,
    surface: Any | None,
    virtual: ObjectModel,
    scan_points: np.ndarray | None = None,
    scan_plan: ScanPlan | None = None,
    T_table_nominal: np.ndarray | None = None,
    goal_tre_m: float | None = None,
) -> list[Path]:
    """The run's figures: registration.png (scenarios.outputs.registration_figure) when a
    surface match ran (the scan's object points `scan_points` (N, 3) in the table frame, else
    the points the match used); targets.png (each target's achieved error,
    the exported program's on a controller without absolute accuracy, and the predicted
    TRE, with the goals); methods.png when several localization methods
    ran side by side (each one's pose error and target errors); scan_plan.png with the
    scan's plan (scenarios.outputs.scan_plan_figure)."""
    import matplotlib

    matplotlib.use("Agg")

    written = []
    located = None if surface is None else surface.localization
    if located is not None:
        points = located.points_used if scan_points is None else scan_points
        written.append(_registration_figure(folder, result, located.result, virtual, points))
    if result.primary.targets:
        written.append(_targets_figure(folder, result))
    if scan_plan is not None and T_table_nominal is not None and scan_plan.chosen:
        written.append(
            write_atomic(
                folder / "scan_plan.png",
                lambda tmp: write_scan_plan_figure(
                    tmp, scan_plan, T_table_nominal, virtual.mesh.vertices, goal_tre_m
                ),
            )
        )
    if len(result.methods) > 1 and any(r.targets for r in result.methods):
        written.append(_methods_figure(folder, result))
    return written


def _registration_figure(
    folder: Path,
    result: RunResult,
    match: MatchResult,
    virtual: ObjectModel,
    points: np.ndarray,
) -> Path:
    """registration.png: the surface match `match` of the scan's points (N, 3) [m, table
    frame] on the model, with each target of the primary method that is a burr hole marked
    with its achieved error and predicted TRE."""
    primary = result.primary
    holes = {h.name: h.p_entry for h in virtual.burr_holes}
    tre = dict(zip((t.name for t in primary.targets), primary.predicted_tre_m, strict=False))
    marks = tuple(
        TargetMark(t.name, holes[t.name], t.error_m, tre.get(t.name, float("nan")))
        for t in primary.targets
        if t.name in holes
    )
    return write_atomic(
        folder / "registration.png",
        lambda tmp: write_registration_figure(tmp, match, virtual, points, marks),
    )


def _targets_figure(folder: Path, result: RunResult) -> Path:
    """targets.png: each target's achieved error [mm] with the primary method's pose, beside
    the exported program's on a controller without absolute accuracy (when it ran to the
    end on every target) and the predicted TRE, each target's error budget (the bound it
    stays within at 95 %), with the job's goals."""
    import matplotlib.pyplot as plt

    primary = result.primary
    names = [t.name for t in primary.targets]
    fig, ax = plt.subplots(figsize=(7, 4.6))
    x = np.arange(len(names))
    exported = result.exported_program
    by_name = {} if exported is None else {t.name: t.error_m for t in exported.targets}
    bars = [("the job's touches (calibrated model)", [t.error_m for t in primary.targets])]
    if exported is not None and exported.status == "complete" and set(names) <= set(by_name):
        label = f"program.mod ({exported.compensation}), controller w/o abs. acc."
        bars.append((label, [by_name[n] for n in names]))
    if primary.predicted_tre_m:
        bars.append(("predicted TRE", list(primary.predicted_tre_m)))
    width = 0.8 / len(bars)
    for k, (label, values) in enumerate(bars):
        offset = (k - (len(bars) - 1) / 2) * width
        ax.bar(x + offset, np.array(values) * 1e3, width, label=label)
    budget = result.budget
    if budget is not None:
        bound = {t.name: t.bound_m for t in budget.targets}
        if set(names) <= set(bound):
            reach = "within reach" if budget.within_reach else "goal at risk"
            ax.plot(
                x, [bound[n] * 1e3 for n in names], "k_", ms=40, mew=2,
                label=f"error budget, 95 % ({reach})",
            )  # fmt: skip
    goals = (
        ("target_error_max_m", "r", "--", "max"),
        ("target_error_rms_m", "orange", ":", "rms"),
    )
    for name, colour, style, label in goals:
        if name in result.checks:
            limit = result.checks[name].limit_m * 1e3
            ax.axhline(limit, color=colour, ls=style, lw=1, label=f"goal {label} {limit:g} mm")
    ax.set_xticks(x, names, rotation=20)
    ax.set_ylabel("[mm]")
    ax.set_title(f"target errors ({primary.method} pose)")
    # Below the axes: inside, the legend hides the bars of the middle targets.
    fig.legend(
        *ax.get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=8, markerscale=0.4
    )
    fig.tight_layout(rect=(0.0, 0.14, 1.0, 1.0))
    path = _save(fig, folder / "targets.png")
    plt.close(fig)
    return path


_LABELS = {"surface": "3D surface matching", "probe": "2D IR edge probing"}


def _methods_figure(folder: Path, result: RunResult) -> Path:
    """methods.png: the localization methods side by side: pose error in rotation and
    translation, and the achieved error of each target with each method's pose."""
    import matplotlib.pyplot as plt

    reports = result.methods
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(12, 4), width_ratios=(1, 1, 2))
    colours = ("tab:blue", "tab:orange", "tab:green")
    labels = [_LABELS.get(r.method, r.method) for r in reports]
    for ax, values, unit, title in (
        (a, [np.nan if r.pose is None else r.pose.rotation_error_deg for r in reports], "deg",
         "pose error, rotation"),
        (b, [np.nan if r.pose is None else r.pose.translation_error_m * 1e3 for r in reports],
         "mm", "pose error, translation"),
    ):  # fmt: skip
        ax.bar(range(len(reports)), values, color=colours[: len(reports)])
        ax.set_xticks(range(len(reports)), labels, rotation=10)
        ax.set_ylabel(f"[{unit}]")
        ax.set_title(title)
    names = list(dict.fromkeys(t.name for r in reports for t in r.targets))
    x = np.arange(len(names))
    width = 0.8 / len(reports)
    for k, report in enumerate(reports):
        errors = {t.name: t.error_m * 1e3 for t in report.targets}
        c.bar(
            x + (k - (len(reports) - 1) / 2) * width,
            [errors.get(n, np.nan) for n in names],
            width,
            color=colours[k % len(colours)],
            label=labels[k],
        )
    c.set_xticks(x, names, rotation=10)
    c.set_ylabel("[mm]")
    c.set_title("tool tip against the true target")
    c.legend()
    title = f"{result.job}, seed {result.seed}"
    if result.pick is not None:
        pick = result.pick
        title += (
            f": lifted {pick.lifted_m * 1e3:.1f} mm, slip {pick.slip_m * 1e3:.2f} mm, put down "
            f"{pick.placed_displacement_m * 1e3:.2f} mm from where it was"
        )
    fig.suptitle(title)
    fig.tight_layout()
    path = _save(fig, folder / "methods.png")
    plt.close(fig)
    return path


def _save(fig: Figure, path: Path) -> Path:
    return write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
