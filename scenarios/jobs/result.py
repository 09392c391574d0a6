"""The result of a cell job: one typed value built by the runner from the stages' results and
the evaluator's, written to results.json in one place (`RunResult.to_json`).

Lengths [m], angles [deg] where the name says so, times [s]. "status" is "complete" when the
program ran, "refused" when the localization or its verification was not accepted (no
motion towards the object), "aborted" when the controller's supervision stopped the cell;
the runner adds "incomplete" when a run fails or is interrupted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rich.table import Table
from rich.text import Text

from scenarios.realcell.evaluation import (
    CalibrationReport,
    PickEvaluation,
    PoseEvaluation,
    TargetEvaluation,
)


@dataclass(frozen=True, eq=False)
class MatchReport:
    """The surface match: its figures (registration.MatchResult) and the pose it gave."""

    rms_m: float
    ambiguity: float
    verdict: str
    reason: str
    seconds: float
    points_used: int
    inlier_fraction: float
    T_table_object: np.ndarray
    starts: int = 1


@dataclass(frozen=True, eq=False)
class MethodReport:
    """One localization method: its pose against the truth (None if it found none), whether
    its pose was accepted and why not, the targets executed with its pose, the predicted TRE
    at each target (surface matching only), and the IR readings (probing only)."""

    method: str
    accepted: bool
    reason: str
    pose: PoseEvaluation | None
    targets: tuple[TargetEvaluation, ...] = ()
    predicted_tre_m: tuple[float, ...] = ()
    readings: int | None = None

    def errors(self) -> np.ndarray:
        """Achieved tip errors of the method's targets (K,) [m]."""
        return np.array([t.error_m for t in self.targets])


@dataclass(frozen=True, eq=False)
class RunResult:
    """The whole run.

    Attributes:
        status, reason: "complete" or "refused", and why it was refused.
        job, seed, model: the configuration's name, its seed, the object's model.
        scan_points: object points of the scan (0 without a scan).
        match: the surface match, or None (no scan, too few points, or probing only).
        methods: each localization method, in the configuration's order (the first one's
            pose drives the program).
        checks: the goals (name -> limit [m]) and whether each holds.
        pick: the pick measured on the true part, and the gripper's distance from the true
            grasp frame, if the job picks.
        calibration: the calibration's figures and the arm's true TCP error.
        timings: wall time per stage [s].
        motion_after_match_s: controller time spent moving after the verdict [s].
        tool_in_hand: the tool at the end of the run.
        table_position_m: the table position of the program, if one ran.
        robot: the cell's arm; program_file: the robot program written for its controller
            (program.mod for an ABB arm), or None (the targets are in targets.csv/json).
        exported_program: that program run on the real cell by a controller without
            absolute accuracy (compensation, target error rms and max, each target's error),
            or None.
        stage: the stage that refused the run or in which the supervision aborted it.
        faults: each fault injected into the real cell, and the stage that detected it
            (or "missed"); supervision: what the controller's supervision and the stages'
            checks saw (stage, time, code, message, action), in order.
    """

    status: str
    reason: str
    job: str
    seed: int
    model: str
    scan_points: int
    match: MatchReport | None
    methods: tuple[MethodReport, ...]
    checks: dict[str, tuple[float, bool]]
    pick: PickEvaluation | None
    grasp_error_m: float | None
    calibration: CalibrationReport
    timings: dict[str, float]
    motion_after_match_s: float
    tool_in_hand: str | None
    table_position_m: float | None
    robot: str = "irb2400"
    program_file: str | None = None
    exported_program: dict[str, Any] | None = None
    stage: str | None = None
    faults: tuple[dict[str, Any], ...] = ()
    supervision: tuple[dict[str, Any], ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def primary(self) -> MethodReport:
        """The method whose pose drove the program."""
        return self.methods[0]

    def to_json(self) -> dict[str, Any]:
        """The results.json mapping (numpy values as plain numbers, None for missing)."""
        primary = self.primary
        errors = primary.errors()
        registration: dict[str, Any] = {"method": primary.method, "verdict": "rejected"}
        if self.match is not None:
            m = self.match
            registration.update(
                rms_m=m.rms_m,
                ambiguity=m.ambiguity,
                verdict=m.verdict,
                reason=m.reason,
                seconds=m.seconds,
                points_used=m.points_used,
                inlier_fraction=m.inlier_fraction,
                T_table_object=m.T_table_object,
                starts=m.starts,
            )
        surface = next((r for r in self.methods if r.method == "surface"), None)
        if surface is not None and surface.pose is not None:
            registration.update(
                rotation_error_deg=surface.pose.rotation_error_deg,
                translation_error_m=surface.pose.translation_error_m,
            )
        if surface is not None and not surface.accepted:
            registration.setdefault("reason", surface.reason)
        names = [t.name for t in primary.targets]
        predicted = dict(zip(names, primary.predicted_tre_m, strict=False))
        return {
            "status": self.status,
            "reason": self.reason,
            "job": self.job,
            "seed": self.seed,
            "model": self.model,
            "scan_points": self.scan_points,
            "registration": registration,
            "methods": {r.method: _method_json(r) for r in self.methods},
            "targets": [
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
                for t in primary.targets
            ],
            "target_error_rms_m": _rms(errors),
            "target_error_max_m": float(errors.max()) if len(errors) else None,
            "checks": {
                name: {"limit_m": limit, "met": met} for name, (limit, met) in self.checks.items()
            },
            "pick": None if self.pick is None else self.pick.to_json(),
            "grasp_error_m": self.grasp_error_m,
            "calibration": self.calibration.to_json(),
            "timings_s": dict(self.timings),
            "motion_after_match_s": self.motion_after_match_s,
            "tool_in_hand": self.tool_in_hand,
            "table_position_m": self.table_position_m,
            "robot": self.robot,
            "program_file": self.program_file,
            "exported_program": self.exported_program,
            "stage": self.stage,
            "faults": list(self.faults),
            "supervision": list(self.supervision),
            **self.extra,
        }


def _rms(errors: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(errors**2))) if len(errors) else None


def _method_json(report: MethodReport) -> dict[str, Any]:
    errors = report.errors()
    out: dict[str, Any] = {
        "accepted": report.accepted,
        "reason": report.reason,
        "rotation_error_deg": None if report.pose is None else report.pose.rotation_error_deg,
        "translation_error_m": None if report.pose is None else report.pose.translation_error_m,
        "targets": [{"name": t.name, "error_m": t.error_m} for t in report.targets],
        "target_error_rms_m": _rms(errors),
        "target_error_max_m": float(errors.max()) if len(errors) else None,
    }
    if report.readings is not None:
        out["ir_readings"] = report.readings
    return out


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.3f}"


def results_table(results: dict[str, Any]) -> Table:
    """A rich table of a cell job's results.json mapping."""
    table = Table(title=f"{results['job']} run, seed {results['seed']}: {results['status']}")
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
    for t in results.get("targets", []):
        add(
            f"{t['name']}: error / reg. share / pred. TRE [mm]",
            f"{_mm(t['error_m'])} / {_mm(t.get('registration_error_m'))} / "
            f"{_mm(t.get('predicted_tre_m'))}",
        )
    for name, check in results.get("checks", {}).items():
        label = name.removesuffix("_m").replace("_", " ")
        add(
            f"{label} [mm] (goal <= {check['limit_m'] * 1e3:g})",
            f"{_mm(results.get(name))} ({'met' if check['met'] else 'missed'})",
        )
    exported = results.get("exported_program") or {}
    if exported.get("status") == "complete":
        add(
            f"program.mod ({exported.get('compensation')}), nominal controller: RMS / max [mm]",
            f"{_mm(exported.get('target_error_rms_m'))} / "
            f"{_mm(exported.get('target_error_max_m'))}",
        )
    elif exported.get("status") == "refused":
        add("program.mod refused by the controller", str(exported.get("reason")))
    for method, row in results.get("methods", {}).items():
        rot = row.get("rotation_error_deg")
        add(
            f"{method}: pose error [deg, mm]",
            "-" if rot is None else f"{rot:.3f}, {_mm(row.get('translation_error_m'))}",
        )
        if len(results.get("methods", {})) > 1:
            add(
                f"{method}: target error RMS / max [mm]",
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
