"""The assembly job (the seed's original use): a part at an unknown pose on the table.

Two ways to locate it are compared on the same real cell:
- 2D adjusting: IR edge probing of the flat part's edges (position and heading only);
- 3D surface matching: laser scan matched to the part's virtual model (full pose), searched
  without the 2D pose (registration.mode "auto"; "refine" would start from it instead).
Then the gripper picks the part at its grasp frame (3D pose): it closes across the upright's
top edge, lifts the part 40 mm, holds it, puts it down where it took it (the gripper goes back
to the pick pose, so the part needs no new pose estimate) and opens. The part is a loose body
on the table (the table carries it by friction; it does not slide while the part is in the
gripper). After the put-down the program's own idea of where the part is remains the located
pose: the screws are then driven from above with the screwer, once with each method's pose.
The evaluator reports each method's pose error, the achieved screw-tip errors (against where
the part really is at each screw), and the pick measured on the true part: how high it rose,
how far it slipped in the fingers and how far the put-down moved it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from cell import nominal_T_base_table
from models import BurrHole, ObjectModel, builtin_model, real_model
from registration import Acceptance, MeshModel
from scenarios.jobs.config import AssemblyConfig
from scenarios.offline.calibration_step import calibrate_arm
from scenarios.offline.localization import localize
from scenarios.offline.probing import EdgeProbe, probe_part
from scenarios.offline.program import (
    OfflineProgram,
    Operation,
    burr_hole_operations,
    change_tool_safely,
    execute_program,
    plan_program,
)
from scenarios.offline.scan import crop_to_object, execute_scan, plan_scan
from scenarios.realcell.evaluation import TargetEvaluation, calibration_results
from scenarios.realcell.setup import build_job_cell, model_error

Progress = Callable[[str], None]
MM = 1e-3
#: IR probe lines of the bracket's base plate (part frame): two across the front edge
#: (y = +25 mm), one across the left edge (x = -40 mm), clear of its holes and upright.
BRACKET_PROBES = (
    EdgeProbe("front 1", np.array([-15, 5, 0]) * MM, np.array([-15, 50, 0]) * MM,
              np.array([0.0, 1.0, 0.0]), 25 * MM),
    EdgeProbe("front 2", np.array([15, 5, 0]) * MM, np.array([15, 50, 0]) * MM,
              np.array([0.0, 1.0, 0.0]), 25 * MM),
    EdgeProbe("left", np.array([-15, 16, 0]) * MM, np.array([-65, 16, 0]) * MM,
              np.array([-1.0, 0.0, 0.0]), 40 * MM),
)  # fmt: skip
#: Height of the bracket's base plate [m] (the step the IR sensor sees).
BRACKET_PLATE_M = 6 * MM
#: Pick: finger opening around the upright [m], lift height [m] and speed [m/s], hold [s].
GRIPPER_OPEN_M = 0.03
LIFT_M = 0.04
LIFT_SPEED = 0.05
HOLD_S = 1.0
#: Screwer speed and time at each screw [rad/s], [s].
SCREW_SPEED = 20.0
SCREW_SECONDS = 0.5


def screw_holes(model: ObjectModel) -> tuple[BurrHole, ...]:
    """The part's screw frames driven from above (z within 25 deg of straight down), as
    targets: entry at the frame's origin, direction its z axis."""
    holes = []
    for frame in model.frames:
        z = frame.T_part_frame[:3, 2]
        if frame.kind == "screw" and z[2] < -0.9:
            holes.append(BurrHole(frame.name, frame.T_part_frame[:3, 3], z, 0.01))
    return tuple(holes)


def _grasp_operation(model: ObjectModel) -> Operation:
    """The grasp frame turned 90 deg about its z so that the fingers close across the
    part's y (the upright's thickness)."""
    T = np.array(model.frame("grasp").T_part_frame)
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    T[:3, :3] = T[:3, :3] @ Rz
    return Operation("grasp", T, 0.08)


def _method_summary(
    pose: Any, targets: tuple[TargetEvaluation, ...], prefix: str
) -> dict[str, Any]:
    errors = np.array([t.error_m for t in targets])
    return {
        "rotation_error_deg": pose.rotation_error_deg,
        "translation_error_m": pose.translation_error_m,
        "targets": [{"name": t.name.removeprefix(prefix), "error_m": t.error_m} for t in targets],
        "target_error_rms_m": float(np.sqrt(np.mean(errors**2))) if len(errors) else None,
        "target_error_max_m": float(errors.max()) if len(errors) else None,
    }


def run_assembly(
    config: AssemblyConfig,
    folder: Path,
    progress: Progress | None = None,
    recording: Any | None = None,
) -> dict[str, Any]:
    """Run the assembly job; returns the results."""
    from scenarios.outputs import files as outputs

    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    model = builtin_model(config.part)
    virtual = replace(model, burr_holes=screw_holes(model))
    real, _ = real_model(virtual, model_error(config.noise), seed=config.seed)
    crop_margin_m = config.placement.range_xy_m + 0.02
    cell = build_job_cell(
        virtual,
        real,
        config.placement,
        config.noise,
        config.calibration,
        config.seed,
        stream=6,
        crop_margin_m=crop_margin_m,
        recording=recording,
        name="part",
        loose=True,  # aluminium (2700 kg/m^3): about 0.13 kg
        rgba=(0.7, 0.72, 0.78, 1.0),
    )
    controller, evaluator, log = cell.controller, cell.evaluator, cell.log
    T_table_nominal, box = cell.T_table_nominal, cell.box
    timings["setup"] = time.perf_counter() - t0

    # Kinematic calibration: both methods and the program then use the calibrated arm.
    nominal = controller.kinematics
    calibration = None
    if config.calibration.enabled:
        t0 = time.perf_counter()
        calibration = calibrate_arm(controller, config.calibration, config.seed, say, log.bodies)
        timings["calibrate"] = time.perf_counter() - t0

    # 2D: IR edge probing.
    t0 = time.perf_counter()
    probed = probe_part(
        controller,
        BRACKET_PROBES,
        T_table_nominal,
        config.probe_height_m,
        BRACKET_PLATE_M,
        progress=say,
    )
    timings["probe"] = time.perf_counter() - t0
    log.bodies()

    # 3D: laser scan and surface matching.
    t0 = time.perf_counter()
    plan = plan_scan(controller.kinematics, box, config.scan, controller.read_joints())
    scan = execute_scan(controller, plan, config.scan, say)
    keep = crop_to_object(scan.points_table, box, crop_margin_m)
    points = scan.points_table[keep]
    timings["scan"] = time.perf_counter() - t0
    outputs.write_ply(folder / "scan.ply", points)
    if recording is not None:
        recording.log_scan(scan, keep, controller.kinematics)
    t0 = time.perf_counter()
    acceptance = Acceptance(
        max_rms=config.registration.max_rms_m,
        min_inlier_fraction=config.registration.min_inlier_fraction,
        max_ambiguity=config.registration.max_ambiguity,
        max_predicted_tre=config.registration.max_predicted_tre_m,
    )
    located = localize(
        points,
        MeshModel(virtual.mesh.vertices, virtual.mesh.faces),
        config.registration.max_points,
        acceptance,
        config.seed,
        config.registration.voxel_m,
        config.registration.mode,
        probed.T_table_object,  # used by mode "refine" only
        scan.line_pass[scan.line_index][keep],
        config.registration.pass_sigma_m,
        targets_model=np.array([h.p_entry for h in virtual.burr_holes]),
    )
    timings["register"] = time.perf_counter() - t0
    result = located.result
    say(f"match: {result.verdict} (rms {result.rms * 1e3:.3f} mm, {result.seconds:.2f} s)")
    if recording is not None:
        recording.log_icp(result, virtual)
    s0 = controller.table_position()
    pose_2d = evaluator.pose_error(nominal_T_base_table(s0) @ probed.T_table_object)
    pose_3d = evaluator.pose_error(nominal_T_base_table(s0) @ located.T_table_object)
    accepted = result.verdict == "accepted"

    # Grasp with the 3D pose, then screw with each method's pose.
    t0 = time.perf_counter()
    programs: dict[str, OfflineProgram] = {}
    grasp_error_m = None
    pick = None
    targets: dict[str, tuple[TargetEvaluation, ...]] = {}
    if accepted:
        kin, q0 = controller.kinematics, controller.read_joints()
        grasp = plan_program(
            kin,
            controller.T_flange_tcp("gripper"),
            "gripper",
            (_grasp_operation(virtual),),
            located.T_table_object,
            q0,
            spins=2,
        )
        change_tool_safely(controller, "gripper")
        controller.set_gripper(GRIPPER_OPEN_M)
        T_base_touch = grasp.operations[0].T_base_touch
        T_base_lift = T_base_touch.copy()
        T_base_lift[2, 3] += LIFT_M

        def pick_and_put_down(name: str) -> None:
            evaluator.record_touch(name, "gripper")  # at rest, fingers open around it
            controller.set_gripper(0.0)  # squeeze: force-limited fingers stop on the upright
            evaluator.record_touch("pick: closed", "gripper")
            controller.move_linear(T_base_lift, speed_m_s=LIFT_SPEED, settle_s=HOLD_S)
            evaluator.record_touch("pick: lifted", "gripper")
            log.moved("lift")
            controller.move_linear(T_base_touch, speed_m_s=LIFT_SPEED)  # where it was taken
            controller.set_gripper(GRIPPER_OPEN_M)

        execute_program(controller, grasp, 0.05, on_touch=pick_and_put_down, on_move=log.moved)
        evaluator.record_touch("pick: placed", "gripper")  # gripper retreated
        grasp_error_m = evaluator.frame_error("grasp", "grasp")
        pick = evaluator.pick("grasp", "pick: closed", "pick: lifted", "pick: placed")
        say(
            f"grasp: gripper within {grasp_error_m * 1e3:.2f} mm of the true grasp frame; "
            f"lifted {pick.lifted_m * 1e3:.1f} mm, slip {pick.slip_m * 1e3:.3f} mm, put down "
            f"{pick.placed_displacement_m * 1e3:.3f} mm / {pick.placed_rotation_deg:.3f} deg "
            "from where it was"
        )
        operations = burr_hole_operations(virtual.burr_holes, 0.05, config.touch_offset_m)
        for method, T_table_object in (
            ("laser_3d", located.T_table_object),
            ("ir_2d", probed.T_table_object),
        ):
            program = plan_program(
                kin,
                controller.T_flange_tcp("screwer"),
                "screwer",
                tuple(replace(op, name=f"{method}:{op.name}") for op in operations),
                T_table_object,
                controller.read_joints(),
            )
            programs[method] = program

            def drive(name: str) -> None:
                evaluator.record_touch(name, "screwer")
                controller.spin_screwer(SCREW_SPEED, SCREW_SECONDS)

            execute_program(controller, program, 0.02, on_touch=drive, on_move=log.moved)
            targets[method] = evaluator.targets(
                config.touch_offset_m, virtual, program.T_base_object, prefix=f"{method}:"
            )
            say(
                f"{method}: screws driven, errors "
                + ", ".join(f"{t.error_m * 1e3:.2f}" for t in targets[method])
                + " mm"
            )
    timings["execute"] = time.perf_counter() - t0
    if "laser_3d" in programs:
        outputs.write_program(folder / "program.mod", programs["laser_3d"], T_table_nominal)
        if recording is not None:
            recording.log_targets(programs["laser_3d"], targets["laser_3d"])
    timings["total"] = time.perf_counter() - t_total
    # The arm's accuracy, from the truth, where the job used it: scan lines and screws.
    q_job = scan.line_q[:: max(1, len(scan.line_q) // 60)]
    touches = [p.q_touch for program in programs.values() for p in program.operations]
    if touches:
        q_job = np.vstack([q_job, *touches])
    predicted = result.predicted_tre(np.array([h.p_entry for h in virtual.burr_holes])).tre
    rows_3d = targets.get("laser_3d", ())
    errors = np.array([t.error_m for t in rows_3d])
    results = {
        "status": "complete" if accepted else "refused",
        "reason": "" if accepted else result.reason,
        "scenario": "assembly",
        "seed": config.seed,
        "part": config.part,
        "scan_points": len(points),
        "registration": {
            "rms_m": result.rms,
            "rotation_error_deg": pose_3d.rotation_error_deg,
            "translation_error_m": pose_3d.translation_error_m,
            "ambiguity": result.ambiguity,
            "verdict": result.verdict,
            "reason": result.reason,
            "seconds": result.seconds,
            "mode": config.registration.mode,
            "T_table_object": located.T_table_object,
        },
        "targets": [
            {
                "name": t.name.removeprefix("laser_3d:"),
                "error_m": t.error_m,
                "predicted_tre_m": float(p),
                "registration_error_m": t.registration_error_m,
            }
            for t, p in zip(rows_3d, predicted, strict=False)
        ],
        "target_error_rms_m": float(np.sqrt(np.mean(errors**2))) if len(errors) else None,
        "target_error_max_m": float(errors.max()) if len(errors) else None,
        "methods": {
            "ir_2d": _method_summary(pose_2d, targets.get("ir_2d", ()), "ir_2d:")
            | {"ir_readings": probed.readings},
            "laser_3d": _method_summary(pose_3d, rows_3d, "laser_3d:"),
        },
        "grasp_error_m": grasp_error_m,
        "pick": None
        if pick is None
        else {
            "lifted_m": pick.lifted_m,
            "slip_m": pick.slip_m,
            "placed_displacement_m": pick.placed_displacement_m,
            "placed_rotation_deg": pick.placed_rotation_deg,
        },
        "calibration": calibration_results(evaluator, nominal, calibration, q_job, "screwer"),
        "timings_s": {
            k: timings.get(k)
            for k in ("setup", "calibrate", "probe", "scan", "register", "execute", "total")
        },
    }
    if config.output.plots:
        outputs.write_assembly_plot(folder, results)
    return results
