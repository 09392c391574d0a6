"""A cell job reported against the truth, once its stages have run (`finish_job`): each
localization method's pose and targets, the pick, the exported program run in the real cell
by a controller without absolute accuracy, the calibration's figures, the goals, the faults
and what detected them, the run's status; the run's figures. The evaluator is read here and
in the runner (scenarios.jobs.pipeline), nowhere else."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from cell.cell_errors import SupervisionError
from cell.robot_arm import Robot
from models.atomic import write_text
from models.model import ObjectModel
from scenarios.configuration.job_config import JobConfig
from scenarios.irc5.remote_controller import RemoteController
from scenarios.jobs.exported_run import (
    EXECUTION_FILE,
    JobTargets,
    execute_in_cell,
    job_targets,
    read_program,
)
from scenarios.jobs.job_plan import JobPlan
from scenarios.jobs.job_run import JobRun
from scenarios.jobs.network_job import TwinTouches, run_exported_remote
from scenarios.outputs import run_files as outputs
from scenarios.outputs import toolchain_exports as exports
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.syntax import RapidError
from scenarios.realcell.evaluation import Evaluator, calibration_report
from scenarios.realcell.setup import JobCell
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.evaluations import (
    CalibrationFigures,
    PickEvaluation,
    PoseEvaluation,
    TargetEvaluation,
    TouchMeasure,
)
from scenarios.results.exported_result import ExportedRun
from scenarios.results.json_converter import unstructure
from scenarios.results.method_reports import MatchReport, MethodReport
from scenarios.results.run import GoalCheck, RunResult, RunStatus
from scenarios.stages.loop import StagesRun
from scenarios.stages.state import JobState, LocatedPose

Progress = Callable[[str], None]


def finish_job(
    config: JobConfig, plan: JobPlan, job: JobRun, ran: StagesRun, t_total: float
) -> RunResult:
    """The job's result once its stages ran (or the supervision stopped them), against the
    truth; its program run as exported; its figures written."""
    state, aborted, say = ran.state, ran.aborted, job.run.say
    controller, evaluator = job.cell.controller, job.cell.evaluator
    methods = config.localization.methods
    if aborted is not None:
        say(f"aborted in {ran.stopped_in}: {aborted}")
    pose_errors = job.pose_errors or job.measure(
        state.poses if aborted is not None else state.ordered(methods), state.model
    )
    ordered = state.ordered(methods) or (LocatedPose(methods[0], None, False, str(aborted)),)
    primary = ordered[0]
    if aborted is None and not primary.accepted:
        say(f"refused: {primary.reason}; no motion towards the object")
    motion_after_match_s = controller.time_s - job.time_at_verdict_s
    programs = {} if aborted is not None else state.programs.operations
    touch_offset = 0.0 if plan.user is not None else config.operations.touch_offset_m
    reports = tuple(
        method_report(
            pose, programs.get(pose.method), job.cell.touches, plan.virtual, touch_offset,
            f"{pose.method}:" if config.operations.per_method else "",
            pose_errors.get(pose.method),
        )
        for pose in ordered
    )  # fmt: skip
    pick, grasp_error = pick_report(config, state, evaluator, aborted is None, say)
    exported = _exported(config, plan, job, reports[0], primary)
    calibration_figures = _calibration_figures(config, job, state)
    checks = goal_checks(config, reports[0])
    spoke = job.run.spoke()
    faults = () if evaluator is None else evaluator.faults(spoke)
    for fault in faults:
        say(f"fault {fault.name}: {'detected in ' if fault.detected else ''}{fault.detected_by}")
    budget = job.run.budget
    status, reason, stopped_in = run_status(aborted, ran.stopped_in, primary, state, budget)
    job.cell.log.phase("end", _ending(status, reason, stopped_in, reports[0]))
    job.timings["total"] = time.perf_counter() - t_total
    program = job.exported.program
    result = RunResult(
        status=status,
        reason=reason,
        job=config.name,
        seed=config.seed,
        model=config.cell.object.model,
        scan_points=0 if state.scanned is None else len(state.scanned.points_table),
        match=_match_report(state.pose("surface")),
        methods=reports,
        checks=checks,
        pick=pick,
        grasp_error_m=grasp_error,
        calibration=calibration_figures,
        timings=job.timings,
        motion_after_match_s=motion_after_match_s,
        tool_in_hand=controller.tool_in_hand,
        table_position_m=None if program is None else program.table_position_m,
        robot=controller.robot.name,
        home_deg=tuple(np.rad2deg(controller.robot.q_home).round(3).tolist()),
        limits_deg=_limits_deg(controller.robot),
        program_file=job.exported.program_file,
        exported_program=exported,
        stage=stopped_in,
        faults=faults,
        supervision=spoke,
        scan_plan=None
        if plan.scan_plan is None
        else plan.scan_plan.summary(None if state.scanned is None else state.scanned.scan_time_s),
        model_cache=plan.model_cache,
        plan_cache=plan.plan_cache,
        verifications=tuple(job.verifications),
        tool_checks=tuple(job.run.tool_checks),
        cell_time_s=controller.time_s - job.started_s,
        budget=budget,
    )
    if config.output.plots:
        _figures(config, plan, job.folder, result, state)
    return result


def _limits_deg(robot: Robot) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The arm's joint window (lower, upper) [deg], rounded to 1e-3 deg."""
    kin = robot.kinematics()
    return (
        tuple(np.rad2deg(kin.lower).round(3).tolist()),
        tuple(np.rad2deg(kin.upper).round(3).tolist()),
    )


def pick_report(
    config: JobConfig, state: JobState, evaluator: Evaluator | None, ran: bool, say: Progress
) -> tuple[PickEvaluation | None, float | None]:
    """The pick measured on the true part, and the gripper's distance from the true grasp
    frame [m], if the job picked (and `ran` to the end) with the truth at hand."""
    pick = config.operations.pick
    if state.programs.pick is None or pick is None or not ran or evaluator is None:
        return None, None
    frame = pick.frame
    evaluation = evaluator.pick(frame, "pick: closed", "pick: lifted", "pick: placed", frame)
    grasp_error = evaluator.frame_error(frame, frame)
    say(
        f"pick: gripper within {grasp_error * 1e3:.2f} mm of the true grasp frame; lifted "
        f"{evaluation.lifted_m * 1e3:.1f} mm, slip {evaluation.slip_m * 1e3:.3f} mm, put "
        f"down {evaluation.placed_displacement_m * 1e3:.3f} mm from where it was"
    )
    return evaluation, grasp_error


def _exported(
    config: JobConfig, plan: JobPlan, job: JobRun, report: MethodReport, primary: LocatedPose
) -> ExportedRun | None:
    """The exported program's targets shown in the recording, and the program run as
    exported in the real cell, if the job runs it."""
    program, program_file = job.exported.program, job.exported.program_file
    if program is None:
        return None
    if job.recording is not None:
        job.recording.log_targets(
            job.cell.controller.time_s,
            program,
            report.targets,
            None if primary.localization is None else primary.localization.result,
            target_points(plan.virtual, report.targets),
        )
    if program_file is None or not config.export.execute:
        return None
    t0 = time.perf_counter()
    job.cell.log.phase("exported program", f"{program_file} on the nominal controller")
    touches = job.cell.touches
    if isinstance(touches, TwinTouches):  # across the network: the controller runs it
        assert isinstance(job.cell.controller, RemoteController)
        exported = run_exported_remote(
            job.cell.controller, touches, job.folder, program_file, job.run.say,
            job.exported.compensation,
        )  # fmt: skip
    else:
        targets = job_targets(config, plan.virtual, plan.user)
        exported = run_exported(
            job.cell, job.folder, program_file, targets, job.run.say, job.exported.compensation
        )
    job.timings["export_execute"] = time.perf_counter() - t0
    return exported


def _calibration_figures(config: JobConfig, job: JobRun, state: JobState) -> CalibrationFigures:
    """The arm's URDF as the job's controller computes it (calibrated if it was), and the
    arm's accuracy from the truth where the job used it: scan lines and targets."""
    controller, calibration = job.cell.controller, state.calibration
    nominal = controller.nominal_kinematics
    exports.write_robot_urdf(
        job.folder, controller.robot, nominal, None if calibration is None else calibration.links
    )
    q_job = np.empty((0, 6))
    if state.scanned is not None:
        line_q = state.scanned.scan.line_q
        q_job = line_q[:: max(1, len(line_q) // 60)]
    touches = [p.q_touch for prog in state.programs.operations.values() for p in prog.operations]
    if touches:
        q_job = np.vstack([q_job, *touches])
    if len(q_job) == 0:
        q_job = np.array([controller.read_joints()])
    if job.cell.evaluator is None:  # no truth in this process: the calibration's own figures
        return CalibrationFigures(
            None if calibration is None else calibration.summary(), None, None, 0
        )
    return calibration_report(
        job.cell.evaluator, nominal, calibration, q_job, config.operations.tool
    )


def goal_checks(config: JobConfig, report: MethodReport) -> dict[str, GoalCheck]:
    """The job's goals on the driving method's target errors, by name."""
    errors = report.errors()
    checks: dict[str, GoalCheck] = {}
    if not len(errors):
        return checks
    for name, limit, value in (
        ("target_error_rms_m", config.checks.target_error_rms_m, np.sqrt(np.mean(errors**2))),
        ("target_error_max_m", config.checks.target_error_max_m, errors.max()),
    ):
        if limit is not None:
            checks[name] = GoalCheck(limit, bool(value <= limit))
    return checks


def run_status(
    aborted: SupervisionError | None,
    stopped_in: str | None,
    primary: LocatedPose,
    state: JobState,
    budget: ErrorBudget | None = None,
) -> tuple[RunStatus, str, str | None]:
    """The run's status ("complete", "at_risk", "refused", "aborted"), its reason, and the
    stage that refused it or in which the supervision stopped it. A program that ran is
    "at_risk" when its error `budget` does not put the job's goals within reach."""
    if aborted is not None:
        return "aborted", str(aborted), stopped_in
    if primary.accepted:
        if budget is not None and not budget.within_reach:
            return "at_risk", "goal at risk: " + "; ".join(budget.risks), None
        return "complete", "", None
    by = state.refused_by or ("register" if primary.method == "surface" else "probe")
    return "refused", primary.reason, by


def _ending(status: str, reason: str, stopped_in: str | None, report: MethodReport) -> str:
    """The recording's last line: how the run ended, and its target errors."""
    ending = {
        "complete": "complete",
        "at_risk": f"complete, {reason}",
        "refused": f"refused: {reason}",
    }.get(status, f"aborted in {stopped_in}: {reason}")
    errors = report.errors()
    if len(errors):
        ending += (
            f"; target error rms {np.sqrt(np.mean(errors**2)) * 1e3:.3f} mm, max "
            f"{errors.max() * 1e3:.3f} mm"
        )
    return ending


def _figures(
    config: JobConfig, plan: JobPlan, folder: Path, result: RunResult, state: JobState
) -> None:
    """The run's figures (scenarios.outputs.run_files)."""
    scan = config.localization.scan
    outputs.write_figures(
        folder,
        result,
        state.pose("surface"),
        plan.virtual,
        None if state.scanned is None else state.scanned.points_table,
        plan.scan_plan,
        plan.T_table_nominal,
        scan.planning.goal_tre_m if scan.plan == "auto" else None,
    )


def method_report(
    pose: LocatedPose,
    program: OfflineProgram | None,
    touches: TouchMeasure,
    virtual: ObjectModel,
    touch_offset_m: float,
    prefix: str,
    pose_error: PoseEvaluation | None,
) -> MethodReport:
    """What one localization method's pose gave, against the truth: the achieved tool tips of
    its `program` (None: it ran none) at the true targets, named without the method's
    `prefix`, with each target's predicted TRE beside them."""
    targets: tuple[TargetEvaluation, ...] = ()
    if program is not None:
        targets = tuple(
            replace(t, name=t.name.removeprefix(prefix))
            for t in touches.targets(touch_offset_m, virtual, program.T_base_object, prefix)
        )
    predicted: tuple[float, ...] = ()
    if pose.localization is not None:
        holes = np.array([h.p_entry for h in virtual.burr_holes])
        tre = pose.localization.result.predicted_tre(holes).tre
        by_name = dict(zip((h.name for h in virtual.burr_holes), tre, strict=True))
        predicted = tuple(float(by_name[t.name]) for t in targets)
    return MethodReport(
        pose.method,
        pose.accepted,
        pose.reason,
        pose_error,
        targets,
        predicted,
        None if pose.probe is None else pose.probe.readings,
    )


def target_points(virtual: ObjectModel, targets: tuple[TargetEvaluation, ...]) -> np.ndarray | None:
    """The virtual targets (K, 3) [m] (model frame) of evaluated `targets`, by name, or None
    if a target is not one of the model's burr holes (a user's program)."""
    holes = {h.name: h.p_entry for h in virtual.burr_holes}
    if not targets or any(t.name not in holes for t in targets):
        return None
    return np.array([holes[t.name] for t in targets])


# -- the runner ---------------------------------------------------------------------------------


def run_exported(
    cell: JobCell,
    folder: Path,
    program_file: str,
    targets: JobTargets,
    say: Progress,
    compensation: str = "",
) -> ExportedRun:
    """Run the exported program in the real cell as a controller without absolute accuracy
    would (scenarios.jobs.exported_run), written to EXECUTION_FILE; its summary, or its refusal
    (a RAPID error) or its stop (the supervision) with the reason. `compensation`: what the
    export wrote it with (a user's module written back states none in its text), else what
    the module states."""
    try:
        executed = execute_in_cell(
            cell, read_program(folder / program_file), targets, say, refetch=True
        )
        if compensation:
            executed = replace(executed, compensation=compensation)
    except RapidError as exc:  # a controller would stop the program there
        say(f"{program_file} on the nominal controller: refused: {exc}")
        return ExportedRun("refused", str(exc))
    except SupervisionError as exc:  # its supervision stopped the cell
        say(f"{program_file} on the nominal controller: aborted: {exc}")
        return ExportedRun("aborted", str(exc))
    write_text(folder / EXECUTION_FILE, json.dumps(unstructure(executed), indent=2) + "\n")
    say(
        f"{program_file} ({executed.compensation}) on the nominal controller: "
        f"target error rms {(executed.rms_m or 0) * 1e3:.3f} mm, max "
        f"{(executed.max_m or 0) * 1e3:.3f} mm"
    )
    return executed.summary()


def _match_report(pose: LocatedPose | None) -> MatchReport | None:
    if pose is None or pose.localization is None:
        return None
    located = pose.localization
    m = located.result
    return MatchReport(
        m.rms,
        m.ambiguity,
        m.verdict,
        m.reason,
        m.seconds,
        len(located.points_used),
        m.inlier_fraction,
        located.T_table_object,
        m.starts,
    )
