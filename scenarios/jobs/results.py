"""The results of a run: the results.json mapping and the table printed at the end."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from rich.table import Table
from rich.text import Text

from scenarios.jobs.config import SkullConfig
from scenarios.realcell.evaluation import PoseEvaluation, TargetEvaluation

if TYPE_CHECKING:
    from scenarios.offline.localization import Localization

#: Goals of the skull job with the default noise [m].
GOAL_RMS_M = 0.5e-3
GOAL_MAX_M = 1.0e-3


def skull_results(
    config: SkullConfig,
    *,
    scan_points: int,
    located: Localization | None,
    accepted: bool,
    reason: str,
    pose: PoseEvaluation | None,
    targets: tuple[TargetEvaluation, ...],
    predicted_tre: np.ndarray | None,
    target_names: list[str],
    timings: dict[str, float],
) -> dict[str, Any]:
    """The results.json mapping of a skull (or user-model) run. "status" is "complete" when
    the program ran, "refused" when the match was not accepted (no motion towards the object)."""
    registration: dict[str, Any] = {
        "rms_m": None,
        "rotation_error_deg": None,
        "translation_error_m": None,
        "ambiguity": None,
        "verdict": "rejected",
        "reason": reason,
        "seconds": timings.get("register"),
        "points_used": 0,
        "inlier_fraction": None,
    }
    if located is not None:
        r = located.result
        registration.update(
            rms_m=r.rms,
            ambiguity=r.ambiguity,
            verdict=r.verdict,
            seconds=r.seconds,
            points_used=len(located.points_used),
            inlier_fraction=r.inlier_fraction,
            T_table_object=located.T_table_object,
        )
    if pose is not None:
        registration.update(
            rotation_error_deg=pose.rotation_error_deg,
            translation_error_m=pose.translation_error_m,
        )
    predicted = {}
    if predicted_tre is not None:
        predicted = {n: float(v) for n, v in zip(target_names, predicted_tre, strict=True)}
    rows = [
        {
            "name": t.name,
            "error_m": t.error_m,
            "predicted_tre_m": predicted.get(t.name),
            "axis_error_deg": t.axis_error_deg,
            "depth_error_m": t.depth_error_m,
            "registration_error_m": t.registration_error_m,
            "p_true_base_m": t.p_true_base,
            "p_achieved_base_m": t.p_achieved_base,
        }
        for t in targets
    ]
    errors = np.array([t.error_m for t in targets])
    return {
        "status": "complete" if accepted else "refused",
        "reason": "" if accepted else reason,
        "scenario": config.scenario,
        "model": config.model,
        "seed": config.seed,
        "scan_points": scan_points,
        "registration": registration,
        "targets": rows,
        "target_error_rms_m": float(np.sqrt(np.mean(errors**2))) if len(errors) else None,
        "target_error_max_m": float(errors.max()) if len(errors) else None,
        "goals": {"target_error_rms_m": GOAL_RMS_M, "target_error_max_m": GOAL_MAX_M},
        "timings_s": {
            k: timings.get(k)
            for k in ("setup", "calibrate", "scan", "register", "execute", "total")
        },
    }


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.3f}"


def results_table(results: dict[str, Any]) -> Table:
    """A rich table of a skull or assembly run's results."""
    table = Table(title=f"{results['scenario']} run, seed {results['seed']}: {results['status']}")
    table.add_column("quantity")
    table.add_column("value", justify="right")

    def add(label: str, value: str) -> None:
        table.add_row(Text(label), Text(value))  # Text: "[mm]" is not markup

    reg = results.get("registration", {})
    cal = results.get("calibration") or {}
    if cal.get("enabled"):
        add(
            "calibration residual RMS before / after [mm]",
            f"{_mm(cal.get('residual_rms_before_m'))} / {_mm(cal.get('residual_rms_after_m'))}",
        )
        add(
            "true TCP error nominal / calibrated arm, mean [mm]",
            f"{_mm(cal.get('tcp_error_nominal_mean_m'))} / "
            f"{_mm(cal.get('tcp_error_calibrated_mean_m'))}",
        )
    add("scan points (object)", str(results.get("scan_points")))
    add("match verdict", str(reg.get("verdict")))
    add("match rms [mm]", _mm(reg.get("rms_m")))
    add("match ambiguity", "-" if reg.get("ambiguity") is None else f"{reg['ambiguity']:.2f}")
    rot = reg.get("rotation_error_deg")
    add("pose rotation error [deg]", "-" if rot is None else f"{rot:.4f}")
    add("pose translation error [mm]", _mm(reg.get("translation_error_m")))
    for t in results.get("targets", []):
        add(
            f"{t['name']}: error / reg. share / pred. TRE [mm]",
            f"{_mm(t['error_m'])} / {_mm(t.get('registration_error_m'))} / "
            f"{_mm(t.get('predicted_tre_m'))}",
        )
    add("target error RMS [mm] (goal <= 0.5)", _mm(results.get("target_error_rms_m")))
    add("target error max [mm] (goal <= 1.0)", _mm(results.get("target_error_max_m")))
    for method, row in results.get("methods", {}).items():
        rot = row.get("rotation_error_deg")
        add(
            f"{method}: pose error [deg, mm]",
            "-" if rot is None else f"{rot:.3f}, {_mm(row.get('translation_error_m'))}",
        )
        add(
            f"{method}: screw error RMS / max [mm]",
            f"{_mm(row.get('target_error_rms_m'))} / {_mm(row.get('target_error_max_m'))}",
        )
    if results.get("grasp_error_m") is not None:
        add("grasp error [mm]", _mm(results["grasp_error_m"]))
    pick = results.get("pick")
    if pick:
        add(
            "pick: lifted / slip / put-down moved [mm]",
            f"{_mm(pick['lifted_m'])} / {_mm(pick['slip_m'])} / "
            f"{_mm(pick['placed_displacement_m'])}",
        )
    for key, value in results.get("timings_s", {}).items():
        add(f"time {key} [s]", "-" if value is None else f"{value:.1f}")
    if results.get("reason"):
        add("reason", str(results["reason"]))
    return table
