"""The skull job (the seed's biomedical application), all in physics.

1. the real phantom is fixed on the sliding table at a pose drawn around the nominal one;
2. the robot fetches the laser; a scan plan made in the virtual cell runs on the real cell;
3. surface matching of the scan to the virtual model gives T_table_object and its quality;
   an ambiguous or poor match stops the run before any motion towards the phantom;
4. the burr-hole operations authored on the virtual model are corrected, solved and executed
   with the pointer (the screwer's tip);
5. the evaluator (the only reader of the truth) measures the achieved tips.

`--model PATH` runs the same pipeline on a user's mesh (targets from a file beside it, or
generated on its upper surface).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from cell import nominal_T_base_table
from models import ObjectModel, load_model, real_model
from registration import Acceptance, MeshModel
from scenarios.jobs.config import SkullConfig
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.calibration_step import calibrate_arm
from scenarios.offline.localization import localize
from scenarios.offline.program import (
    OfflineProgram,
    burr_hole_operations,
    execute_program,
    plan_program,
)
from scenarios.offline.scan import ScanData, crop_to_object, execute_scan, plan_scan
from scenarios.offline.targets import generate_targets, read_targets, targets_path
from scenarios.realcell.evaluation import calibration_results
from scenarios.realcell.setup import build_job_cell, model_error

Progress = Callable[[str], None]


def virtual_and_real(config: SkullConfig) -> tuple[ObjectModel, ObjectModel]:
    """The virtual model (with its targets) and its real entity (model error, seeded)."""
    model, _warnings = load_model(config.model, seed=config.seed, units=config.units)
    if config.targets_file is not None:
        model = replace(model, burr_holes=read_targets(config.targets_file, config.units))
    elif not model.burr_holes:
        beside = targets_path(config.model)
        holes = (
            read_targets(beside, config.units)
            if beside.is_file()
            else generate_targets(model, seed=config.seed)
        )
        model = replace(model, burr_holes=holes)
    real, _ = real_model(model, model_error(config.noise), seed=config.seed)
    return model, real


def run_skull(
    config: SkullConfig,
    folder: Path,
    progress: Progress | None = None,
    recording: Any | None = None,
) -> dict[str, Any]:
    """Run the skull job; returns the results (see scenarios.jobs.results for the keys)."""
    from scenarios.jobs.results import skull_results
    from scenarios.outputs import files as outputs

    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    timings: dict[str, float] = {}

    t0 = time.perf_counter()
    say(f"model {config.model!r}: virtual and real entity")
    virtual, real = virtual_and_real(config)
    crop_margin_m = config.placement.range_xy_m + 0.03
    cell = build_job_cell(
        virtual,
        real,
        config.placement,
        config.noise,
        config.calibration,
        config.seed,
        stream=5,
        crop_margin_m=crop_margin_m,
        recording=recording,
    )
    controller, evaluator, log = cell.controller, cell.evaluator, cell.log
    T_table_nominal, box = cell.T_table_nominal, cell.box
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    timings["setup"] = time.perf_counter() - t0

    # Kinematic calibration: the scan, the IK and the program then use the calibrated arm.
    nominal = controller.kinematics
    calibration: CalibrationResult | None = None
    if config.calibration.enabled:
        t0 = time.perf_counter()
        calibration = calibrate_arm(controller, config.calibration, config.seed, say, log.bodies)
        timings["calibrate"] = time.perf_counter() - t0
        log.bodies()

    # Scan: planned in the virtual cell, executed on the real one.
    t0 = time.perf_counter()
    plan = plan_scan(controller.kinematics, box, config.scan, controller.read_joints())
    say(f"scan plan: {len(plan)} passes at table positions {[p.table_position_m for p in plan]}")
    scan: ScanData = execute_scan(controller, plan, config.scan, say)
    keep = crop_to_object(scan.points_table, box, crop_margin_m)
    object_points = scan.points_table[keep]
    timings["scan"] = time.perf_counter() - t0
    say(f"scan: {len(scan.points_table)} points, {len(object_points)} on the object")
    if recording is not None:
        recording.log_scan(scan, keep, controller.kinematics)
    log.bodies()
    outputs.write_ply(folder / "scan.ply", object_points)

    # Registration.
    t0 = time.perf_counter()
    acceptance = Acceptance(
        max_rms=config.registration.max_rms_m,
        min_inlier_fraction=config.registration.min_inlier_fraction,
        max_ambiguity=config.registration.max_ambiguity,
        max_predicted_tre=config.registration.max_predicted_tre_m,
    )
    if len(object_points) < config.scan.min_points:
        located = None
        reason = (
            f"the scan has {len(object_points)} object points, fewer than the "
            f"{config.scan.min_points} required"
        )
    else:
        located = localize(
            object_points,
            shape,
            config.registration.max_points,
            acceptance,
            config.seed,
            config.registration.voxel_m,
            config.registration.mode,
            T_table_nominal,
            scan.line_pass[scan.line_index][keep],
            config.registration.pass_sigma_m,
            targets_model=np.array([h.p_entry for h in virtual.burr_holes]),
        )
        reason = located.result.reason
    timings["register"] = time.perf_counter() - t0
    if located is not None:
        r = located.result
        say(
            f"match: {r.verdict} (rms {r.rms * 1e3:.3f} mm, ambiguity {r.ambiguity:.2f}, "
            f"{r.seconds:.2f} s)"
        )
        if recording is not None:
            recording.log_icp(r, virtual)

    accepted = located is not None and located.result.verdict == "accepted"
    time_at_verdict_s = controller.time_s
    program: OfflineProgram | None = None
    executed = ()
    t0 = time.perf_counter()
    if accepted:
        assert located is not None
        operations = burr_hole_operations(
            virtual.burr_holes, config.program.approach_m, config.program.touch_offset_m
        )
        program = plan_program(
            controller.kinematics,
            controller.T_flange_tcp(config.program.tool),
            config.program.tool,
            operations,
            located.T_table_object,
            controller.read_joints(),
            config.program.spins,
        )
        say(f"program: {len(program.operations)} operations at table {program.table_position_m} m")
        executed = execute_program(
            controller,
            program,
            config.program.touch_speed_m_s,
            on_touch=lambda target: evaluator.record_touch(target, config.program.tool),
            on_move=log.moved,
        )
    else:
        say(f"refused: {reason}; no motion towards the object")
    timings["execute"] = time.perf_counter() - t0
    motion_after_match_s = controller.time_s - time_at_verdict_s

    # Evaluation (truth) and outputs.
    pose = None
    if located is not None:
        s_eval = program.table_position_m if program is not None else controller.table_position()
        pose = evaluator.pose_error(nominal_T_base_table(s_eval) @ located.T_table_object)
    target_evals = ()
    if executed and program is not None:
        target_evals = evaluator.targets(
            config.program.touch_offset_m, virtual, program.T_base_object
        )
    targets_model = np.array([h.p_entry for h in virtual.burr_holes])
    predicted = located.result.predicted_tre(targets_model).tre if located is not None else None
    if program is not None:
        outputs.write_program(folder / "program.mod", program, T_table_nominal)
    if recording is not None and program is not None:
        recording.log_targets(program, target_evals)
    timings["total"] = time.perf_counter() - t_total
    results = skull_results(
        config,
        scan_points=len(object_points),
        located=located,
        accepted=accepted,
        reason=reason,
        pose=pose,
        targets=target_evals,
        predicted_tre=predicted,
        target_names=[h.name for h in virtual.burr_holes],
        timings=timings,
    )
    results["motion_after_match_s"] = motion_after_match_s
    # The arm's accuracy, from the truth, where the job used it: scan lines and touches.
    q_job = scan.line_q[:: max(1, len(scan.line_q) // 60)]
    if program is not None:
        q_job = np.vstack([q_job, *[p.q_touch for p in program.operations]])
    results["calibration"] = calibration_results(
        evaluator, nominal, calibration, q_job, config.program.tool
    )
    results["tool_in_hand"] = controller.tool_in_hand
    if program is not None:
        results["table_position_m"] = program.table_position_m
    if config.output.plots:
        outputs.write_plots(folder, located, target_evals, predicted, virtual)
    return results
