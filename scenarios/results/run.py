"""The result of a cell job: one typed value built by the runner from the stages' results and
the evaluator's, written to results.json by the results' converter
(scenarios.results.json_converter, which lays it out) and read back from it
(scenarios.results.results_file.read_results).

Lengths [m], angles [deg] where the name says so, times [s]. "status" is "complete" when the
program ran with its goals within reach of the error budget, "at_risk" when it ran but the
budget does not put its goals within reach (the reason says which and why), "refused" when
the localization or its verification was not accepted (no motion towards the object),
"aborted" when the controller's supervision stopped the cell.
A run that failed or was interrupted leaves an `IncompleteRun` instead. The reports of its
localization (the surface match, each method) are scenarios.results.method_reports'.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from scenarios.results.budget_result import ErrorBudget
from scenarios.results.edge import JsonObject
from scenarios.results.evaluations import CalibrationFigures, PickEvaluation, TargetEvaluation
from scenarios.results.events import FaultOutcome, SupervisionEvent
from scenarios.results.exported_result import ExportedRun
from scenarios.results.method_reports import MatchReport, MethodReport
from scenarios.results.scan_plan_result import ScanPlanSummary
from scenarios.results.verification_result import TcpCheck, Verification
from scenarios.scenario_errors import ScenarioError

#: The version of results.json's layout that the results' converter writes and reads.
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


def check_schema(data: JsonObject) -> None:
    """Refuse a results.json that is not a finished cell job's of this schema (the results'
    converter reads one only after this)."""
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
