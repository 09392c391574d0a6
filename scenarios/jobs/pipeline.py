"""The one pipeline of every cell job: calibrate, scan, localize, program, execute, evaluate,
export.

The job is first planned in its virtual cell (`plan_job`). The runner (`run_cell_job`)
alone holds the real cell's truth: it sets the cell up (scenarios.realcell), hands the
stages (scenarios.stages) a context with the controller API, the virtual model and the
planning settings, nothing else, and asks the evaluator afterwards what really happened.
The stages see the cell as a program on a real controller would. What the run records of
the truth (the evaluator's moments, the rerun recording of the bodies) goes through the
hooks the runner passes to the stages.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell import Controller, Kinematics, nominal_T_base_table
from cell.errors import CellConfigError, SupervisionError
from cell.robots import Robot, make_robot
from cell.sim.faults import FAULT_KINDS, Fault
from models.atomic import write_text
from models.model import ObjectModel
from models.registry import real_model
from scenarios.errors import ScenarioError
from scenarios.jobs.config import JobConfig, RobotSection
from scenarios.jobs.exported import EXECUTION_FILE, execute_in_cell, job_targets, read_program
from scenarios.jobs.result import MatchReport, MethodReport, RunResult
from scenarios.jobs.run_log import RunLog
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.cell_model import CellModel
from scenarios.offline.operations import (
    UserProgram,
    check_program_frame,
    grasp_operation,
    program_operations,
    program_targets,
    read_user_program,
    target_operations,
    virtual_model,
)
from scenarios.offline.placement import nominal_pose
from scenarios.offline.program import OfflineProgram
from scenarios.offline.reach import check_reach
from scenarios.offline.scan import (
    ObjectBox,
)
from scenarios.offline.scan_plan import ScanPlan
from scenarios.offline.settings import PlanningSettings
from scenarios.outputs import exports
from scenarios.outputs import files as outputs
from scenarios.rapid.module import RapidError, with_oframe
from scenarios.rapid.writer import Filter
from scenarios.realcell.cell_log import CellLog
from scenarios.realcell.ct import ct_virtual_model
from scenarios.realcell.evaluation import Evaluator, calibration_report
from scenarios.realcell.setup import JobCell, build_job_cell, model_error
from scenarios.stages.calibrate import calibrate_stage
from scenarios.stages.context import StageContext
from scenarios.stages.execute import execute_stage
from scenarios.stages.probe import probe_stage
from scenarios.stages.program import ProgramStage, check_stage, program_stage
from scenarios.stages.register import LocatedPose, stray_message, surface_pose
from scenarios.stages.scan import ScanStage, job_scan_plan, scan_stage
from scenarios.stages.verify import verify_stage

Progress = Callable[[str], None]


# -- the runner's hooks: the truth recorded at the stages' moments -------------------------------
class RunHooks:
    """The stages' moments go to the evaluator (it records the truth then), their moves to
    the recording (the true bodies, the arm's path), their progress and their checks to the
    run's `say` and `detect`."""

    def __init__(
        self,
        evaluator: Evaluator,
        log: CellLog,
        say: Progress,
        detect: Callable[[str, str, str], None],
    ) -> None:
        self._evaluator = evaluator
        self._log = log
        self.say = say
        self.detect = detect

    def moment(self, name: str, tool: str) -> None:
        self._evaluator.record_touch(name, tool)

    def moved(self, what: str) -> None:
        self._log.moved(what)


def target_points(virtual: ObjectModel, targets: tuple[Any, ...]) -> np.ndarray | None:
    """The virtual targets (K, 3) [m] (model frame) of evaluated `targets`, by name, or None
    if a target is not one of the model's burr holes (a user's program)."""
    holes = {h.name: h.p_entry for h in virtual.burr_holes}
    if not targets or any(t.name not in holes for t in targets):
        return None
    return np.array([holes[t.name] for t in targets])


# -- the runner ---------------------------------------------------------------------------------
def localize_by_surface(
    ctx: StageContext,
    log: CellLog,
    poses: dict[str, LocatedPose],
    model: CellModel,
    enter: Callable[[str], None],
    recording: Any | None,
    timings: dict[str, float],
    folder: Path,
    scan_plan: ScanPlan | None = None,
) -> ScanStage:
    """The scan and its surface match (into `poses["surface"]`), each its own stage."""
    enter("scan")
    t0 = time.perf_counter()
    log.phase("scan", "the laser's passes over the object")
    scanned = scan_stage(ctx, model, scan_plan)
    timings["scan"] = timings.get("scan", 0.0) + time.perf_counter() - t0
    if recording is not None:
        recording.log_scan(scanned.scan, scanned.keep)
    ctx.hooks.moved("view")
    outputs.write_ply(folder / "scan.ply", scanned.points_table)
    enter("register")
    t0 = time.perf_counter()
    prior = poses["probe"].T_table_object if "probe" in poses else None
    log.phase("register", "the scan to the virtual model (its steps on the timeline icp)")
    labels = scanned.scan.line_pass[scanned.scan.line_index][scanned.keep]
    pose = surface_pose(
        scanned.points_table, labels, ctx.virtual, ctx.settings, prior, ctx.hooks.say
    )
    poses["surface"] = pose
    timings["register"] = timings.get("register", 0.0) + time.perf_counter() - t0
    located = pose.localization
    if not pose.accepted:
        ctx.hooks.detect("match_refused", pose.reason, "refused")
    if located is not None:
        stray = stray_message(scanned.points_table, ctx.virtual, located)
        if stray:
            ctx.hooks.detect("scan_outliers", stray, "left out by the match")
    if recording is not None and located is not None:
        recording.log_registration(
            ctx.controller.time_s,
            located.result,
            ctx.virtual,
            scanned.points_table,
            located.points_used,
        )
    return scanned


def object_models(
    config: JobConfig, user: UserProgram | None = None
) -> tuple[ObjectModel, ObjectModel]:
    """The job's object: its virtual model with the operations' targets (from the model, or
    the touches of the user's program; what the planner knows) and its real entity (the
    model error drawn from the seed, or with `model.source: ct` the design itself, the
    virtual model being meshed from its simulated CT: the truth)."""
    obj = config.cell.object
    virtual = virtual_model(
        obj.model,
        obj.units,
        obj.targets_file,
        config.operations.kind,
        config.seed,
        config.model.ct.iso_hu,
    )
    if user is not None:
        virtual = replace(virtual, burr_holes=program_targets(user))
    if config.model.source == "ct":  # the design is the real object; the model is its CT's
        return ct_virtual_model(virtual, config.model.ct, config.seed), virtual
    real, _ = real_model(virtual, model_error(config.cell.noise), seed=config.seed)
    return virtual, real


def job_robot(section: RobotSection) -> Robot:
    """The cell's arm as the job's configuration names it (cell.robots)."""
    home = None if section.home_deg is None else np.deg2rad(section.home_deg)
    limits = None
    if section.limits_deg is not None:
        limits = (np.deg2rad(section.limits_deg[0]), np.deg2rad(section.limits_deg[1]))
    try:
        return make_robot(
            section.model,
            section.flange,
            section.mount_xyz,
            section.mount_yaw_deg,
            home,
            section.vendor,
            limits,
            None if section.speed_deg_s is None else np.deg2rad(section.speed_deg_s),
            None if section.effort_nm is None else np.asarray(section.effort_nm, dtype=float),
        )
    except CellConfigError as exc:
        raise ScenarioError(f"cell.robot: {exc}") from None


def job_cell(
    config: JobConfig,
    virtual: ObjectModel,
    real: ObjectModel,
    robot: Robot,
    recording: Any | None = None,
    faults: tuple[Fault, ...] = (),
) -> JobCell:
    """The job's real cell (scenarios.realcell.setup): the real entity at the true pose drawn
    from the job's seed (its own random stream: fixed or loose), the calibration spheres if
    the job calibrates, the job's arm and rack, the recording's hooks."""
    obj = config.cell.object
    loose = obj.fixing == "loose"
    return build_job_cell(
        virtual,
        real,
        obj.placement,
        config.cell.noise,
        config.calibration,
        config.seed,
        stream=6 if loose else 5,  # the true placement's random stream
        crop_margin_m=config.localization.scan.crop_margin_m,
        recording=recording,
        name=config.object_name,
        loose=loose,
        rgba=(0.7, 0.72, 0.78, 1.0) if loose else (0.9, 0.85, 0.75, 1.0),
        robot=robot,
        rack_xyz=config.cell.rack_xyz,
        faults=faults,
    )


def job_faults(
    config: JobConfig, virtual: ObjectModel, T_table_nominal: np.ndarray
) -> tuple[Fault, ...]:
    """The faults the job's real cell will have (`faults:`), each kind's defaults filled
    in: the job's tool for a payload, and an obstacle standing 5 cm behind the first
    operation's approach point (nominal), where the tool passes on its way there."""
    out = []
    for name, setting in config.faults.active().items():
        kind = FAULT_KINDS[name]
        option = setting.option
        if name == "payload" and option is None:
            option = config.operations.tool
        where: tuple[float, float, float] | None = None
        if name == "obstacle":
            ops = target_operations(virtual, config.operations)
            T = T_table_nominal @ ops[0].T_object_approach
            x, y, z = (float(v) for v in T[:3, 3] - 0.05 * T[:3, 2])
            where = (x, y, z)
        out.append(
            Fault(
                name,
                kind.default if setting.amount is None else setting.amount,
                kind.stage if setting.stage is None else setting.stage,
                option,
                where,
            )
        )
    return tuple(out)


@dataclass(frozen=True, eq=False)
class JobPlan:
    """What a job is before its real cell is built: its planning settings, its arm, the
    user's program (if any), the virtual model and the real entity (the truth: for the real
    cell's set-up only), the nominal pose T_table_object (4, 4), and the scan plan."""

    settings: PlanningSettings
    robot: Robot
    user: UserProgram | None
    virtual: ObjectModel
    real: ObjectModel
    T_table_nominal: np.ndarray
    scan_plan: ScanPlan | None


def plan_job(config: JobConfig, say: Progress) -> JobPlan:
    """The job in its virtual cell, before the real one: the models, whether the arm reaches
    the rack slots, the scan and the operations, and the scan's passes (chosen, or for a
    fixed plan predicted): a job that cannot be done refuses here."""
    obj = config.cell.object
    settings = config.planning()  # all that the stages are told of the job
    say(f"model {obj.model!r}: virtual and real entity")
    if config.model.source == "ct":
        ct = config.model.ct
        say(
            f"model: CT-scanning the real {obj.model} in simulation ("
            + " x ".join(f"{v:g}" for v in ct.voxel_mm)
            + f" mm voxels), meshing its bone at {ct.iso_hu:g} HU"
        )
    robot = job_robot(config.cell.robot)
    if config.operations.program is not None and not robot.rapid:
        raise ScenarioError(
            f"--program takes a RAPID module, which only an ABB arm runs; this cell's arm is "
            f"the {robot.name} ({robot.vendor or 'vendor unknown'})"
        )
    user = None if config.operations.program is None else read_user_program(config.operations)
    virtual, real = object_models(config, user)
    T_table_nominal = nominal_pose(settings.placement, virtual.mesh.vertices)
    if user is not None:
        check_program_frame(user, nominal_T_base_table(user.table_position_m) @ T_table_nominal)
        say(f"program {config.operations.program}: {len(user.operations)} touches")
    # Can this arm do this job here at all? Asked of the virtual cell, before the real one.
    operations = (
        target_operations(virtual, config.operations) if user is None else program_operations(user)
    )
    reach = check_reach(
        robot,
        settings,
        ObjectBox.of(virtual.mesh.vertices, T_table_nominal),
        T_table_nominal,
        operations,
        None
        if config.operations.pick is None
        else grasp_operation(virtual, config.operations.pick),
        None if user is None else (user.table_position_m,),
    )
    say(
        f"reach: the {robot.name} reaches the slots of {', '.join(reach.tools)}, the scan and "
        "the operations in the virtual cell"
    )
    scan_plan = None
    if "surface" in config.localization.methods:
        # The scan's passes, chosen (or, for a fixed plan, predicted) in the virtual cell
        # before the real one moves: a target no pass constrains refuses the job here.
        scan_plan = job_scan_plan(
            robot, settings, virtual, T_table_nominal,
            np.array([op.T_object_touch[:3, 3] for op in operations]), say,
            tuple(op.name for op in operations),
        )  # fmt: skip
    return JobPlan(settings, robot, user, virtual, real, T_table_nominal, scan_plan)


def run_cell_job(
    config: JobConfig,
    folder: Path,
    progress: Progress | None = None,
    recording: Any | None = None,
    stages: Any | None = None,
) -> RunResult:
    """Run a cell job into `folder`; returns its result (written by the caller). `stages`
    (scenarios.jobs.stages.StageTracker) hears each stage as it begins."""
    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    timings: dict[str, float] = {}

    # The virtual model and the real cell (the truth stays here).
    t0 = time.perf_counter()
    plan = plan_job(config, say)
    settings, robot, user = plan.settings, plan.robot, plan.user
    virtual, real, T_table_nominal = plan.virtual, plan.real, plan.T_table_nominal
    scan_plan, obj = plan.scan_plan, config.cell.object
    faults = job_faults(config, virtual, T_table_nominal)
    cell = job_cell(config, virtual, real, robot, recording, faults)
    if recording is not None and scan_plan is not None:
        recording.log_scan_plan(0.0, scan_plan)
    controller, evaluator = cell.controller, cell.evaluator
    log = cell.log
    if faults:
        say("faults injected: " + ", ".join(f.name for f in faults))
    run = RunLog(controller, evaluator, log, say, stages, recording)
    say, enter, detect = run.say, run.enter, run.detect
    hooks = RunHooks(evaluator, log, say, detect)
    ctx = StageContext(controller, virtual, T_table_nominal, cell.box, settings, hooks, user)

    timings["setup"] = time.perf_counter() - t0

    # The stages, under the controller's supervision: a stop ends them (the arm stands
    # backed off and still) and the run reports "aborted" with the stage.
    nominal = controller.nominal_kinematics
    calibration: CalibrationResult | None = None
    model = CellModel.nominal(nominal)
    poses: dict[str, LocatedPose] = {}
    scanned: ScanStage | None = None
    programs = ProgramStage(None, {})
    aborted: SupervisionError | None = None
    pose_errors: dict[str, Any] = {}

    def measure_poses(located: tuple[LocatedPose, ...]) -> dict[str, Any]:
        """Each method's pose against the truth, now (a pick may move the part later)."""
        s0 = controller.table_position()
        return {
            p.method: evaluator.pose_error(model.T_base_table(s0) @ p.T_table_object)
            for p in located
            if p.T_table_object is not None
        }

    refused_by: str | None = None  # the stage that refused, beyond the match's verdict
    time_at_verdict_s = controller.time_s
    methods = config.localization.methods

    def planned() -> ProgramStage:
        """The corrected programs of the accepted pose, checked in the virtual cell before
        they move (stage check; a refusal leaves none and says why)."""
        nonlocal refused_by
        ordered = tuple(poses[m] for m in methods)
        if not ordered[0].accepted:
            return ProgramStage(None, {})
        programs = program_stage(ctx, ordered, model)
        enter("check")
        check = check_stage(ctx, programs)
        if check is None:
            say("check: the corrected program passes in the virtual cell")
            return programs
        detect("premotion", check.summary, "refused")
        poses[methods[0]] = replace(poses[methods[0]], accepted=False, reason=check.summary)
        refused_by = "check"
        return ProgramStage(None, {})

    try:
        # Calibrate: every later stage uses the calibrated arm.
        if config.calibration.enabled:
            enter("calibrate")
            t0 = time.perf_counter()
            log.phase("calibrate", "the arm, the laser and the table, on the spheres")
            calibration = calibrate_stage(ctx)
            timings["calibrate"] = time.perf_counter() - t0
            hooks.moved("view")
            if recording is not None:
                recording.log_calibration(controller.time_s, calibration)
            # What the stages believe of the cell: the calibrated model.
            model = calibration.model

        # Localize: probing first (quick, and the prior of a surface match in mode
        # "refine"), then the scan and the surface match.
        if "probe" in methods:
            enter("probe")
            t0 = time.perf_counter()
            log.phase("probe", "the part's edges with the IR sensor")
            poses["probe"] = probe_stage(ctx)
            timings["probe"] = time.perf_counter() - t0
            hooks.moved("view")
        if "surface" in methods:
            scanned = localize_by_surface(
                ctx, log, poses, model, enter, recording, timings, folder, scan_plan
            )
        time_at_verdict_s = controller.time_s
        t0 = time.perf_counter()
        programs = planned()
        # Verify the correction on the object before any target is touched; if it
        # disagrees, scan and match once more; if it still disagrees, refuse.
        if programs.operations and methods[0] == "surface" and config.verify.enabled:
            for attempt in range(2):
                enter("verify")
                log.phase("verify", "the match on patches of the object, away from the targets")
                assert scanned is not None
                verdict = verify_stage(ctx, poses["surface"], scanned, programs, model)
                if verdict.agrees:
                    break
                message = f"the object disagrees with the match: {verdict.summary()}"
                if attempt == 1:
                    detect("verification", message, "refused")
                    refused_by = "verify"
                    poses["surface"] = replace(
                        poses["surface"], accepted=False, reason=f"verification: {message}"
                    )
                    programs = ProgramStage(None, {})
                    break
                detect("verification", message, "re-scanned and matched again")
                scanned = localize_by_surface(
                    ctx, log, poses, model, enter, recording, timings, folder, scan_plan
                )
                time_at_verdict_s = controller.time_s
                programs = planned()
                if not programs.operations:
                    break
        ordered = tuple(poses[m] for m in methods)
        primary = ordered[0]
        pose_errors = measure_poses(ordered)
        # Program and execute, only if the pose that drives the program is accepted.
        if primary.accepted and programs.operations:
            enter("execute")
            log.phase("execute", f"the program corrected by the {primary.method} pose")
            execute_stage(ctx, programs)
        elif not primary.accepted:
            say(f"refused: {primary.reason}; no motion towards the object")
        timings["execute"] = time.perf_counter() - t0
    except SupervisionError as stop:
        aborted = stop
        say(f"aborted in {run.stage}: {stop}")
        if not pose_errors:
            pose_errors = measure_poses(tuple(poses.values()))
    ordered = tuple(poses[m] for m in config.localization.methods if m in poses)
    if not ordered:  # stopped before any pose
        ordered = (LocatedPose(config.localization.methods[0], None, False, str(aborted)),)
    primary = ordered[0]
    motion_after_match_s = controller.time_s - time_at_verdict_s

    # Evaluate (truth) and export. A user's robtargets are the touch poses themselves.
    touch_offset = 0.0 if user is not None else config.operations.touch_offset_m
    reports = [
        method_report(
            pose,
            None if aborted is not None else programs.operations.get(pose.method),
            evaluator,
            virtual,
            touch_offset,
            f"{pose.method}:" if config.operations.per_method else "",
            pose_errors.get(pose.method),
        )
        for pose in ordered
    ]
    pick_eval = grasp_error = None
    if programs.pick is not None and config.operations.pick is not None and aborted is None:
        frame = config.operations.pick.frame
        pick_eval = evaluator.pick(frame, "pick: closed", "pick: lifted", "pick: placed", frame)
        grasp_error = evaluator.frame_error(frame, frame)
        say(
            f"pick: gripper within {grasp_error * 1e3:.2f} mm of the true grasp frame; lifted "
            f"{pick_eval.lifted_m * 1e3:.1f} mm, slip {pick_eval.slip_m * 1e3:.3f} mm, put "
            f"down {pick_eval.placed_displacement_m * 1e3:.3f} mm from where it was"
        )
    if aborted is None:
        enter("export")
    # An aborted run hands out no program: the cell was not as its model says.
    primary_program = None if aborted is not None else programs.operations.get(primary.method)
    program_file = None
    exported: dict[str, Any] | None = None
    if primary_program is not None:
        filtered = program_filter(
            config.export.compensation, calibration, user, controller, primary_program.tool, say
        )
        program_file = export_program(
            folder,
            primary_program,
            cell.T_table_nominal,
            user,
            controller.robot,
            say,
            nominal,
            filtered,
            None if calibration is None else calibration.kinematics,
        )
        if recording is not None:
            recording.log_targets(
                controller.time_s,
                primary_program,
                reports[0].targets,
                None if primary.localization is None else primary.localization.result,
                target_points(virtual, reports[0].targets),
            )
        if program_file is not None and config.export.execute:
            t0 = time.perf_counter()
            log.phase("exported program", f"{program_file} on the nominal controller")
            exported = run_exported(
                cell, folder, program_file, job_targets(config, virtual, user), say
            )
            timings["export_execute"] = time.perf_counter() - t0
    exports.write_robot_urdf(
        folder, controller.robot, nominal, None if calibration is None else calibration.links
    )
    # The arm's accuracy, from the truth, where the job used it: scan lines and targets.
    q_job = np.empty((0, 6))
    if scanned is not None:
        q_job = scanned.scan.line_q[:: max(1, len(scanned.scan.line_q) // 60)]
    touches = [p.q_touch for prog in programs.operations.values() for p in prog.operations]
    if touches:
        q_job = np.vstack([q_job, *touches])
    if len(q_job) == 0:
        q_job = np.array([controller.read_joints()])
    calibration_figures = calibration_report(
        evaluator, nominal, calibration, q_job, config.operations.tool
    )
    errors = reports[0].errors()
    checks: dict[str, tuple[float, bool]] = {}
    if len(errors):
        for name, limit, value in (
            ("target_error_rms_m", config.checks.target_error_rms_m, np.sqrt(np.mean(errors**2))),
            ("target_error_max_m", config.checks.target_error_max_m, errors.max()),
        ):
            if limit is not None:
                checks[name] = (limit, bool(value <= limit))
    # What the supervision and the checks saw, each in the stage it spoke in, and each
    # fault injected with the stage that detected it (the evaluator: it knows the faults).
    spoke = list(run.spoke())
    fault_report = evaluator.faults(spoke)
    for entry in fault_report:
        by = entry["detected_by"]
        seen = by if by in ("missed", "not injected") else f"detected in {by}"
        say(f"fault {entry['name']}: {seen}")
    if aborted is not None:
        status, reason, stopped_in = "aborted", str(aborted), run.stage
    elif primary.accepted:
        status, reason, stopped_in = "complete", "", None
    else:
        status, reason = "refused", primary.reason
        stopped_in = refused_by or ("register" if primary.method == "surface" else "probe")
    ending = {"complete": "complete", "refused": f"refused: {reason}"}.get(
        status, f"aborted in {stopped_in}: {reason}"
    )
    if len(errors):
        ending += (
            f"; target error rms {np.sqrt(np.mean(errors**2)) * 1e3:.3f} mm, max "
            f"{errors.max() * 1e3:.3f} mm"
        )
    log.phase("end", ending)
    timings["total"] = time.perf_counter() - t_total
    result = RunResult(
        status=status,
        reason=reason,
        job=config.name,
        seed=config.seed,
        model=obj.model,
        scan_points=0 if scanned is None else len(scanned.points_table),
        match=_match_report(poses.get("surface")),
        methods=tuple(reports),
        checks=checks,
        pick=pick_eval,
        grasp_error_m=grasp_error,
        calibration=calibration_figures,
        timings=timings,
        motion_after_match_s=motion_after_match_s,
        tool_in_hand=controller.tool_in_hand,
        table_position_m=None if primary_program is None else primary_program.table_position_m,
        robot=controller.robot.name,
        program_file=program_file,
        exported_program=exported,
        stage=stopped_in,
        faults=tuple(fault_report),
        supervision=tuple(spoke),
        scan_plan=None
        if scan_plan is None
        else scan_plan.to_json(None if scanned is None else scanned.scan_time_s),
    )
    if config.output.plots:
        outputs.write_figures(
            folder,
            result,
            poses.get("surface"),
            virtual,
            None if scanned is None else scanned.points_table,
            scan_plan,
            T_table_nominal,
            config.localization.scan.planning.goal_tre_m
            if config.localization.scan.plan == "auto"
            else None,
        )
    return result


def method_report(
    pose: LocatedPose,
    program: OfflineProgram | None,
    evaluator: Evaluator,
    virtual: ObjectModel,
    touch_offset_m: float,
    prefix: str,
    pose_error: Any,
) -> MethodReport:
    """What one localization method's pose gave, against the truth: the achieved tool tips of
    its `program` (None: it ran none) at the true targets, named without the method's
    `prefix`, with each target's predicted TRE beside them."""
    targets: tuple[Any, ...] = ()
    if program is not None:
        targets = tuple(
            replace(t, name=t.name.removeprefix(prefix))
            for t in evaluator.targets(touch_offset_m, virtual, program.T_base_object, prefix)
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


def program_filter(
    compensation: str,
    calibration: CalibrationResult | None,
    user: UserProgram | None,
    controller: Controller,
    tool: str,
    say: Progress,
) -> Filter | None:
    """The exported program's filter for the calibrated arm (compensation "filtered"), or
    None: the nominal poses, as asked or, said why, when there is no calibrated arm or the
    program is the user's own module (its oframe is corrected, its robtargets kept)."""
    if compensation != "filtered":
        return None
    if calibration is None or user is not None:
        why = (
            "filtering needs the calibrated arm"
            if calibration is None
            else "your own module keeps its robtargets (its oframe is corrected)"
        )
        say(f"program: compensation nominal: {why}")
        return None
    return Filter(
        calibration.kinematics,
        controller.nominal_kinematics,
        controller.T_base_slot(tool),
        controller.q_home,
    )


def run_exported(
    cell: JobCell, folder: Path, program_file: str, targets: Any, say: Progress
) -> dict[str, Any]:
    """Run the exported program in the real cell as a controller without absolute accuracy
    would (scenarios.jobs.exported), written to EXECUTION_FILE; its summary, or its refusal
    (a RAPID error) or its stop (the supervision) with the reason."""
    try:
        executed = execute_in_cell(
            cell, read_program(folder / program_file), targets, say, refetch=True
        )
    except RapidError as exc:  # a controller would stop the program there
        say(f"{program_file} on the nominal controller: refused: {exc}")
        return {"status": "refused", "reason": str(exc)}
    except SupervisionError as exc:  # its supervision stopped the cell
        say(f"{program_file} on the nominal controller: aborted: {exc}")
        return {"status": "aborted", "reason": str(exc)}
    write_text(folder / EXECUTION_FILE, json.dumps(executed.to_json(), indent=2) + "\n")
    say(
        f"{program_file} ({executed.compensation}) on the nominal controller: "
        f"target error rms {(executed.rms_m or 0) * 1e3:.3f} mm, max "
        f"{(executed.max_m or 0) * 1e3:.3f} mm"
    )
    return executed.summary()


def export_program(
    folder: Path,
    program: OfflineProgram,
    T_table_nominal: np.ndarray,
    user: UserProgram | None,
    robot: Robot,
    say: Progress,
    nominal: Kinematics | None = None,
    filtered: Filter | None = None,
    calibrated: Kinematics | None = None,
) -> str | None:
    """The corrected program for the user's controller: the corrected targets as CSV and
    JSON (in the arm's own base frame) and the tool's data, and for an ABB arm program.mod
    (RAPID: the user's own module with its work object's oframe corrected, or one written
    here, filtered for the calibrated arm if `filtered`, its configuration data from the
    `nominal` arm; the targets' link angles from the `calibrated` arm). Returns the
    program's file name, or None for an arm that does not run RAPID."""
    exports.write_targets(folder, program, robot.T_world_base, calibrated)
    exports.write_tooldata(folder, program.tool)
    if not robot.rapid:
        say(
            f"program: no RAPID module for the {robot.name} ({robot.vendor or 'vendor unknown'}"
            "; RAPID is for ABB arms): the corrected targets are in targets.csv and "
            "targets.json"
        )
        return None
    if user is None:
        outputs.write_program(folder / "program.mod", program, T_table_nominal, nominal, filtered)
    else:
        T_base_object = program.T_base_object
        T_uframe_oframe = np.linalg.inv(user.wobj.T_base_uframe) @ T_base_object
        write_text(
            folder / "program.mod", with_oframe(user.module, user.wobj.name, T_uframe_oframe)
        )
    return "program.mod"


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
