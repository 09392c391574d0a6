"""results.json, typed both ways: a run's RunResult written by the results' converter is read
back by `read_results` field for field; files that are not a finished run of this schema are
refused with the reason."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenarios.outputs.run_folder import RunFolder
from scenarios.results.evaluations import (
    CalibrationFigures,
    CalibrationSummary,
    PickEvaluation,
    PoseEvaluation,
    TargetEvaluation,
    TcpError,
)
from scenarios.results.events import FaultOutcome, Injection, SupervisionEvent
from scenarios.results.exported_result import ExportedRun, TargetError
from scenarios.results.json_converter import unstructure
from scenarios.results.method_reports import MatchReport, MethodReport
from scenarios.results.results_file import read_results
from scenarios.results.run import (
    SCHEMA_VERSION,
    GoalCheck,
    IncompleteRun,
    ResultsError,
    RunNotEndedError,
    RunResult,
)
from scenarios.results.scan_plan_result import PassSummary, ScanPlanSummary


def _target(name: str, error_m: float) -> TargetEvaluation:
    return TargetEvaluation(
        name, error_m, 0.5, 2 * error_m, error_m / 2, np.array([0.1, 0.2, 0.3]),
        np.array([0.1, 0.2, 0.3 + error_m]),
    )  # fmt: skip


def _result() -> RunResult:
    surface = MethodReport(
        "surface", True, "", PoseEvaluation(0.04, 2.0e-4),
        (_target("a", 3.0e-4), _target("b", 4.0e-4)), (2.0e-4, 2.5e-4),
    )  # fmt: skip
    probe = MethodReport("probe", True, "", PoseEvaluation(0.2, 8e-4), (), (), 6)
    summary = CalibrationSummary(
        3e-4, 3e-5, 6.5, 8000, 100, 3, 7, ("arm", "table"), {"x1": 1e-4}, (1.5e6, np.inf),
        (1e-4, 0.0, -1e-4), (1e-3, 0.0, 0.0), 4e-4, ((0.0, 1e-5), (2e-5, 0.0)),
    )  # fmt: skip
    plan = ScanPlanSummary(
        "auto", 1, 0.1, 18.7, 18.3, 2.9e-4, (2.9e-4, 2.5e-4), 54,
        (PassSummary("p1", 30.0, 45.0, 0.0, 0.28, -0.2, None, 5.0, 1.0, False),),
    )  # fmt: skip
    return RunResult(
        status="complete", reason="", job="skull", seed=3, model="skull", scan_points=30000,
        match=MatchReport(2.3e-4, 0.0, "accepted", "ok", 0.3, 6000, 1.0, np.eye(4), 9728),
        methods=(surface, probe),
        checks={"target_error_max_m": GoalCheck(1e-3, True)},
        pick=PickEvaluation(0.04, 1e-5, 2e-4, 0.1), grasp_error_m=3e-4,
        calibration=CalibrationFigures(summary, TcpError(7e-4, 9e-4), TcpError(3e-4, 4e-4), 67),
        timings={"scan": 2.0, "total": 20.0}, motion_after_match_s=90.0,
        tool_in_hand="screwer", table_position_m=0.0, program_file="program.mod",
        exported_program=ExportedRun(
            "complete", "", "program.mod", "filtered", 3.9e-4, 5.5e-4,
            (TargetError("a", 3.9e-4),),
        ),
        faults=(
            FaultOutcome("laser_spurious", 0.01, "scan", None,
                         Injection("scan", 12.0, "a patch"), "register", "scan_outliers"),
            FaultOutcome("obstacle", 0.06, None, None, None, "not injected"),
        ),
        supervision=(SupervisionEvent("register", 15.0, "scan_outliers", "12 points", "left"),),
        scan_plan=plan, seconds=21.5,
    )  # fmt: skip


def test_a_result_reads_back_as_written(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path, "skull")
    folder.write_json("results.json", unstructure(_result()))  # as the runner writes it
    written = json.loads(folder.file("results.json").read_text())
    read = read_results(folder.path)
    folder.write_json("again.json", unstructure(read))
    assert json.loads(folder.file("again.json").read_text()) == written
    assert read.schema_version == SCHEMA_VERSION
    assert read.method("probe") is not None and read.method("probe").readings == 6
    assert read.primary.predicted("b") == 2.5e-4
    assert read.target_error_max_m == 4.0e-4
    np.testing.assert_array_equal(read.targets[1].p_achieved_base, [0.1, 0.2, 0.3004])
    assert read.faults[0].detected and not read.faults[1].detected
    assert read.scan_plan is not None and read.scan_plan.through_home == 0
    assert read.calibration.summary is not None
    assert read.calibration.summary.table_coefficients == ((0.0, 1e-5), (2e-5, 0.0))
    # A joint not modelled is infinitely stiff: null in the file, inf again when read.
    assert written["calibration"]["stiffness_nm_rad"] == [1.5e6, None]
    assert read.calibration.summary.stiffness_nm_rad == (1.5e6, np.inf)


def test_the_registration_section_is_the_match_and_the_surface_pose() -> None:
    registration = unstructure(_result())["registration"]
    assert registration["verdict"] == "accepted" and registration["starts"] == 9728
    assert registration["rotation_error_deg"] == 0.04


def test_a_run_that_did_not_end_is_refused_with_its_reason(tmp_path: Path) -> None:
    stopped = IncompleteRun("skull", 0, "interrupted (SIGTERM)", "scan")
    (tmp_path / "results.json").write_text(json.dumps(unstructure(stopped)))
    with pytest.raises(RunNotEndedError, match=r"did not end \(stage scan\): interrupted"):
        read_results(tmp_path / "results.json")


def test_another_schema_and_a_broken_file_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "results.json"
    data = unstructure(_result())
    path.write_text(json.dumps({**data, "schema_version": None}))
    with pytest.raises(ResultsError, match=r"schema version None; this twincell reads version 1"):
        read_results(path)
    path.write_text(json.dumps({k: v for k, v in data.items() if k != "methods"}))
    with pytest.raises(ResultsError, match="missing or bad 'methods'"):
        read_results(path)
    path.write_text("{")
    with pytest.raises(ResultsError, match="is not JSON"):
        read_results(path)
    with pytest.raises(ResultsError, match=r"no results\.json"):
        read_results(tmp_path / "nowhere")
