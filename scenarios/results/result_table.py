"""A cell job's result as a table for the terminal (rich)."""

from __future__ import annotations

from rich.table import Table
from rich.text import Text

from scenarios.results.run import RunResult


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.3f}"


def results_table(result: RunResult) -> Table:
    """A rich table of a cell job's result."""
    table = Table(title=f"{result.job} run, seed {result.seed}: {result.status}")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    budget = result.budget
    bounds = {} if budget is None else {t.name: t.bound_m for t in budget.targets}
    rows = [
        *_calibration_rows(result),
        ("scan points (object)", str(result.scan_points)),
        *_match_rows(result),
        *(
            (
                f"{t.name}: error / reg. share / pred. TRE / budget [mm]",
                f"{_mm(t.error_m)} / {_mm(t.registration_error_m)} / "
                f"{_mm(result.primary.predicted(t.name))} / {_mm(bounds.get(t.name))}",
            )
            for t in result.targets
        ),
        *_check_rows(result),
        *_goal_rows(result),
        *_exported_rows(result),
        *_method_rows(result),
        *_pick_rows(result),
        *((f"time {key} [s]", f"{value:.1f}") for key, value in result.timings.items()),
    ]
    if result.reason:
        rows.append(("reason", result.reason))
    for label, value in rows:
        table.add_row(Text(label), Text(value))  # Text: "[mm]" is not markup
    return table


Rows = list[tuple[str, str]]


def _calibration_rows(result: RunResult) -> Rows:
    figures = result.calibration
    if figures.summary is None:
        return []
    calibrated = None if figures.calibrated is None else figures.calibrated.mean_m
    rows = [
        (
            "calibration residual RMS before / after [mm]",
            f"{_mm(figures.summary.residual_rms_before_m)} / "
            f"{_mm(figures.summary.residual_rms_after_m)}",
        ),
    ]
    summary = figures.summary
    if summary.laser_latency_s is not None and summary.laser_latency_sigma_s is not None:
        rows.append(
            (
                "laser's latency, identified [ms]",
                f"{summary.laser_latency_s * 1e3:.2f} +- {summary.laser_latency_sigma_s * 1e3:.2f}",
            )
        )
    if figures.nominal is not None:
        rows.append(
            (
                "true TCP error nominal / calibrated arm, mean [mm]",
                f"{_mm(figures.nominal.mean_m)} / {_mm(calibrated)}",
            )
        )
    return rows


def _match_rows(result: RunResult) -> Rows:
    match = result.match
    return [
        ("match verdict", "rejected" if match is None else match.verdict),
        ("match rms [mm]", _mm(None if match is None else match.rms_m)),
        ("match ambiguity", "-" if match is None else f"{match.ambiguity:.2f}"),
    ]


def _check_rows(result: RunResult) -> Rows:
    """Each tool's check at the beam (its decision, reading and what it resolves) and the
    error budget's bounds against the goals."""
    rows = [
        (
            f"TCP check {c.tool} (attempt {c.attempt + 1}): read / resolves [mm]",
            f"{c.verdict}: {_mm(c.off_m)} / {_mm(c.resolves_m)}"
            + (" (checked to that only)" if c.decision == "unresolved" else ""),
        )
        for c in result.tool_checks
    ]
    budget = result.budget
    if budget is not None:
        rows.append(
            (
                "error budget: RMS / largest bound [mm] (95 %)",
                f"{_mm(budget.rms_bound_m)} / {_mm(budget.max_bound_m)} "
                f"({'within reach' if budget.within_reach else 'goal at risk'})",
            )
        )
    return rows


def _goal_rows(result: RunResult) -> Rows:
    achieved = {
        "target_error_rms_m": result.target_error_rms_m,
        "target_error_max_m": result.target_error_max_m,
    }
    return [
        (
            f"{name.removesuffix('_m').replace('_', ' ')} [mm] (goal <= {check.limit_m * 1e3:g})",
            f"{_mm(achieved.get(name))} ({'met' if check.met else 'missed'})",
        )
        for name, check in result.checks.items()
    ]


def _exported_rows(result: RunResult) -> Rows:
    exported = result.exported_program
    if exported is None:
        return []
    if exported.status == "complete":
        return [
            (
                f"program.mod ({exported.compensation}), nominal controller: RMS / max [mm]",
                f"{_mm(exported.target_error_rms_m)} / {_mm(exported.target_error_max_m)}",
            )
        ]
    if exported.status == "refused":
        return [("program.mod refused by the controller", exported.reason)]
    return []


def _method_rows(result: RunResult) -> Rows:
    rows: Rows = []
    for report in result.methods:
        pose = report.pose
        rows.append(
            (
                f"{report.method}: pose error [deg, mm]",
                "-"
                if pose is None
                else f"{pose.rotation_error_deg:.3f}, {_mm(pose.translation_error_m)}",
            )
        )
        if len(result.methods) > 1:
            rows.append(
                (
                    f"{report.method}: target error RMS / max [mm]",
                    f"{_mm(report.rms_m)} / {_mm(report.max_m)}",
                )
            )
    return rows


def _pick_rows(result: RunResult) -> Rows:
    rows: Rows = []
    if result.grasp_error_m is not None:
        rows.append(("grasp error [mm]", _mm(result.grasp_error_m)))
    pick = result.pick
    if pick is not None:
        rows.append(
            (
                "pick: lifted / slip / put-down moved [mm]",
                f"{_mm(pick.lifted_m)} / {_mm(pick.slip_m)} / {_mm(pick.placed_displacement_m)}",
            )
        )
    return rows
