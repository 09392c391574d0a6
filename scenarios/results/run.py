"""The result of a cell job: one typed value built by the runner from the stages' results and
the evaluator's, written to results.json in one place (`RunResult.to_json`) and read back
from it (`RunResult.read`, `RunResult.from_json`).

Lengths [m], angles [deg] where the name says so, times [s]. "status" is "complete" when the
program ran with its goals within reach of the error budget, "at_risk" when it ran but the
budget does not put its goals within reach (the reason says which and why), "refused" when
the localization or its verification was not accepted (no motion towards the object),
"aborted" when the controller's supervision stopped the cell.
A run that failed or was interrupted leaves an `IncompleteRun` instead. The reports of its
localization (the surface match, each method) are scenarios.results.method_reports'.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from scenarios.results.budget_result import ErrorBudget
from scenarios.results.edge import JsonObject
from scenarios.results.evaluations import CalibrationFigures, PickEvaluation, TargetEvaluation
from scenarios.results.events import FaultOutcome, SupervisionEvent
from scenarios.results.exported_result import ExportedRun
from scenarios.results.json_converter import structure, unstructure
from scenarios.results.method_reports import MatchReport, MethodReport
from scenarios.results.scan_plan_result import ScanPlanSummary
from scenarios.results.verification_result import TcpCheck, Verification
from scenarios.scenario_errors import ScenarioError

#: The version of results.json's layout that this module writes and reads.
SCHEMA_VERSION = 1

RunStatus = Literal["complete", "at_risk", "refused", "aborted"]
#: The statuses of a run whose program ran to its end.
RAN: tuple[RunStatus, ...] = ("complete", "at_risk")


class ResultsError(ScenarioError, ValueError):
    """A results.json that cannot be read as a run's result."""


class RunNotEndedError(ResultsError):
    """The results.json of a run that failed or was interrupted (status "incomplete")."""


@dataclass(frozen=True)
class GoalCheck:
    """A goal of the job on its target errors: the limit [m] and whether it was met."""

    limit_m: float
    met: bool


def _limits(value: object) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """results.json's "limits_deg": [lower, upper] lists (both empty in older files)."""
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise ValueError(f"limits_deg {value!r}")
    lower, upper = value
    return tuple(float(v) for v in lower), tuple(float(v) for v in upper)


@dataclass(frozen=True, eq=False)
class RunResult:
    """The whole run.

    Attributes:
        status, reason: "complete", "at_risk", "refused" or "aborted", and why.
        job, seed, model: the configuration's name, its seed, the object's model.
        scan_points: object points of the scan (0 without a scan).
        match: the surface match, or None (no scan, too few points, or probing only).
        methods: each localization method, in the configuration's order (the first one's
            pose drives the program).
        checks: the goals, by name (target_error_rms_m, target_error_max_m).
        pick, grasp_error_m: the pick measured on the true part, and the gripper's distance
            from the true grasp frame [m], if the job picks.
        calibration: the calibration's figures and the arm's true TCP error.
        timings: wall time per stage [s].
        motion_after_match_s: controller time spent moving after the verdict [s].
        tool_in_hand: the tool at the end of the run.
        table_position_m: the table position of the program, if one ran.
        robot: the cell's arm; home_deg: its home (6,) [deg]; limits_deg: its joint window
            (lower, upper) [deg] (a file arm's: chosen by the cell unless given);
            program_file: the robot program written for its controller
            (program.mod for an ABB arm), or None (the targets are in targets.csv/json).
        exported_program: that program run on the real cell by a controller without
            absolute accuracy, or None.
        stage: the stage that refused the run or in which the supervision aborted it.
        faults: each fault injected into the real cell, and what detected it; supervision:
            what the controller's supervision and the stages' checks saw, in order.
        scan_plan: the scan's plan, None without a scan.
        tool_checks: the tools' checks at the beam before their program ran (a tool
            seated off is put back and checked again).
        cell_time_s: the cell's clock at the run's end [s] (its simulated time).
        budget: the targets' error budget, made before the first touch from what the job
            measured (scenarios.offline.error_budget), or None (no surface pose drove a program).
        verifications: the verification before the first touch, each time it ran (a
            detected move re-scans, re-matches and verifies again), in order.
        model_cache: the key of the built model read from (or written to) the disk cache
            (models.cache), or None (not a cached model, or the cache turned off);
            plan_cache: the key of the scan plan read from (or written to) it
            (scenarios.offline.plan_cache), or None (no scan, or the cache turned off).
        seconds: the run's wall time [s], set by the runner (None before).
    """

    status: RunStatus
    reason: str
    job: str
    seed: int
    model: str
    scan_points: int
    match: MatchReport | None
    methods: tuple[MethodReport, ...]
    checks: dict[str, GoalCheck]
    pick: PickEvaluation | None
    grasp_error_m: float | None
    calibration: CalibrationFigures
    timings: dict[str, float]
    motion_after_match_s: float
    tool_in_hand: str | None
    table_position_m: float | None
    robot: str = "irb2400"
    home_deg: tuple[float, ...] = ()
    limits_deg: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    program_file: str | None = None
    exported_program: ExportedRun | None = None
    stage: str | None = None
    faults: tuple[FaultOutcome, ...] = ()
    supervision: tuple[SupervisionEvent, ...] = ()
    scan_plan: ScanPlanSummary | None = None
    model_cache: str | None = None
    plan_cache: str | None = None
    verifications: tuple[Verification, ...] = ()
    tool_checks: tuple[TcpCheck, ...] = ()
    cell_time_s: float | None = None
    budget: ErrorBudget | None = None
    seconds: float | None = None
    schema_version: int = field(default=SCHEMA_VERSION)

    @property
    def primary(self) -> MethodReport:
        """The method whose pose drove the program."""
        return self.methods[0]

    def method(self, name: str) -> MethodReport | None:
        """The report of the localization method `name`, or None."""
        return next((r for r in self.methods if r.method == name), None)

    @property
    def targets(self) -> tuple[TargetEvaluation, ...]:
        """The driving method's targets."""
        return self.primary.targets

    @property
    def target_error_rms_m(self) -> float | None:
        return self.primary.rms_m

    @property
    def target_error_max_m(self) -> float | None:
        return self.primary.max_m

    def to_json(self) -> JsonObject:
        """The results.json mapping (plain numbers and lists, None for missing)."""
        primary = self.primary
        return {
            "schema_version": self.schema_version,
            "status": self.status,
            "reason": self.reason,
            "job": self.job,
            "seed": self.seed,
            "model": self.model,
            "scan_points": self.scan_points,
            "registration": self._registration_json(),
            "methods": {r.method: unstructure(r) for r in self.methods},
            "targets": [
                {**unstructure(t), "predicted_tre_m": primary.predicted(t.name)}
                for t in primary.targets
            ],
            "target_error_rms_m": self.target_error_rms_m,
            "target_error_max_m": self.target_error_max_m,
            "checks": {
                name: {"limit_m": c.limit_m, "met": c.met} for name, c in self.checks.items()
            },
            "pick": unstructure(self.pick),
            "grasp_error_m": self.grasp_error_m,
            "calibration": unstructure(self.calibration),
            "timings_s": dict(self.timings),
            "motion_after_match_s": self.motion_after_match_s,
            "tool_in_hand": self.tool_in_hand,
            "table_position_m": self.table_position_m,
            "robot": self.robot,
            "home_deg": list(self.home_deg),
            "limits_deg": [list(self.limits_deg[0]), list(self.limits_deg[1])],
            "program_file": self.program_file,
            "exported_program": unstructure(self.exported_program),
            "stage": self.stage,
            "faults": [unstructure(f) for f in self.faults],
            "supervision": [unstructure(e) for e in self.supervision],
            "scan_plan": unstructure(self.scan_plan),
            "model_cache": self.model_cache,
            "plan_cache": self.plan_cache,
            "verifications": [unstructure(v) for v in self.verifications],
            "tool_checks": [unstructure(c) for c in self.tool_checks],
            "cell_time_s": self.cell_time_s,
            "budget": unstructure(self.budget),
            "seconds": self.seconds,
        }

    def _registration_json(self) -> JsonObject:
        """results.json's "registration": the driving method, the match's figures, and the
        surface pose's error against the truth."""
        out: JsonObject = {"method": self.primary.method, "verdict": "rejected"}
        if self.match is not None:
            out.update(unstructure(self.match))
        surface = self.method("surface")
        if surface is not None and surface.pose is not None:
            out.update(
                rotation_error_deg=surface.pose.rotation_error_deg,
                translation_error_m=surface.pose.translation_error_m,
            )
        if surface is not None and not surface.accepted:
            out.setdefault("reason", surface.reason)
        return out

    @classmethod
    def from_json(cls, data: JsonObject | str | Path) -> RunResult:
        """The result of a results.json mapping (`to_json`), or of the file at a path (see
        `read`); a mapping of another layout or of a run that did not end raises
        ResultsError naming what it found."""
        if isinstance(data, str | Path):
            return cls.read(data)
        _check_layout(data)
        try:
            return cls._from_json(data)
        except (KeyError, TypeError, ValueError) as exc:
            raise ResultsError(
                f"results.json (schema {SCHEMA_VERSION}) of job {data.get('job')!r}: missing or "
                f"bad {exc}"
            ) from None

    @classmethod
    def _from_json(cls, data: JsonObject) -> RunResult:
        registration = data["registration"]
        exported, pick, plan = data["exported_program"], data["pick"], data["scan_plan"]
        return cls(
            status=data["status"],
            reason=str(data["reason"]),
            job=str(data["job"]),
            seed=int(data["seed"]),
            model=str(data["model"]),
            scan_points=int(data["scan_points"]),
            match=structure(registration, MatchReport) if "rms_m" in registration else None,
            methods=tuple(
                structure({"method": m, **d}, MethodReport) for m, d in data["methods"].items()
            ),
            checks={
                name: GoalCheck(float(c["limit_m"]), bool(c["met"]))
                for name, c in data["checks"].items()
            },
            pick=None if pick is None else structure(pick, PickEvaluation),
            grasp_error_m=data["grasp_error_m"],
            calibration=structure(data["calibration"], CalibrationFigures),
            timings={str(k): float(v) for k, v in data["timings_s"].items()},
            motion_after_match_s=float(data["motion_after_match_s"]),
            tool_in_hand=data["tool_in_hand"],
            table_position_m=data["table_position_m"],
            robot=str(data["robot"]),
            home_deg=tuple(float(v) for v in data.get("home_deg", ())),
            limits_deg=_limits(data.get("limits_deg", ((), ()))),
            program_file=data["program_file"],
            exported_program=None if exported is None else structure(exported, ExportedRun),
            stage=data["stage"],
            faults=tuple(structure(f, FaultOutcome) for f in data["faults"]),
            supervision=tuple(structure(e, SupervisionEvent) for e in data["supervision"]),
            scan_plan=None if plan is None else structure(plan, ScanPlanSummary),
            model_cache=data["model_cache"],
            plan_cache=data.get("plan_cache"),
            verifications=tuple(structure(v, Verification) for v in data.get("verifications", ())),
            tool_checks=tuple(structure(c, TcpCheck) for c in data.get("tool_checks", ())),
            cell_time_s=data.get("cell_time_s"),
            budget=None if data.get("budget") is None else structure(data["budget"], ErrorBudget),
            seconds=data["seconds"],
            schema_version=int(data["schema_version"]),
        )

    @classmethod
    def read(cls, path: str | Path) -> RunResult:
        """The result in a run folder's results.json (`path`: the file or its folder)."""
        path = Path(path)
        if path.is_dir():
            path = path / "results.json"
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ResultsError(f"no results.json at {path}") from None
        except json.JSONDecodeError as exc:
            raise ResultsError(f"{path} is not JSON: {exc}") from None
        if not isinstance(data, dict):
            raise ResultsError(f"{path} holds a {type(data).__name__}, not a run's results")
        try:
            return cls.from_json(data)
        except ResultsError as exc:
            raise type(exc)(f"{path}: {exc}") from None


def _check_layout(data: JsonObject) -> None:
    """Refuse a results.json that is not a finished cell job's of this schema."""
    version = data.get("schema_version")
    if data.get("status") == "incomplete":
        raise RunNotEndedError(
            f"the run of job {data.get('job')!r} did not end (stage {data.get('stage')}): "
            f"{data.get('reason')}"
        )
    if version != SCHEMA_VERSION:
        raise ResultsError(
            f"results.json of schema version {version!r}; this twincell reads version "
            f"{SCHEMA_VERSION} (a cell job's results: run the job again to write them)"
        )


@dataclass(frozen=True)
class IncompleteRun:
    """A run that did not end: a failure or an interruption (`reason`) in `stage`."""

    job: str
    seed: int
    reason: str
    stage: str | None = None
    seconds: float | None = None

    status: Literal["incomplete"] = "incomplete"

    def to_json(self) -> JsonObject:
        return {
            "schema_version": SCHEMA_VERSION,
            "status": self.status,
            "reason": self.reason,
            "job": self.job,
            "seed": self.seed,
            "stage": self.stage,
            "seconds": self.seconds,
        }
