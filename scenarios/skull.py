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
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell import (
    ArmErrors,
    CellConfig,
    EncoderNoise,
    FixedMesh,
    FixedPrimitive,
    LaserConfig,
    TableErrors,
    nominal_T_base_table,
)
from cell import make_cell as make_real_cell
from models import ModelErrorSpec, ObjectModel, load_model, real_model
from registration import Acceptance, MatchResult, MeshModel, ScanPasses, invert, match
from scenarios.calibration import CalibrationResult
from scenarios.calibration_step import (
    artifact_fixtures,
    calibrate_arm,
    calibration_results,
    check_artifact_clearance,
)
from scenarios.cell_log import CellLog
from scenarios.config import Noise, SkullConfig
from scenarios.evaluation import Evaluator
from scenarios.placement import draw_true_pose, nominal_pose
from scenarios.program import (
    OfflineProgram,
    burr_hole_operations,
    execute_program,
    plan_program,
)
from scenarios.scan import ObjectBox, ScanData, crop_to_object, execute_scan, plan_scan
from scenarios.targets import generate_targets, read_targets, targets_path

Progress = Callable[[str], None]


@dataclass(frozen=True, eq=False)
class Localization:
    """The matched object pose: T_table_object (4, 4) in the nominal table frame, the match,
    the points used (M, 3) and the number of cropped object points."""

    T_table_object: np.ndarray
    result: MatchResult
    points_used: np.ndarray
    object_points: int


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
    spec = ModelErrorSpec(
        deformation_rms=config.noise.model_deformation_rms_m,
        noise_rms=config.noise.model_noise_rms_m,
    )
    real, _ = real_model(model, spec, seed=config.seed)
    return model, real


def cell_config(
    noise: Noise, seed: int, fixtures: tuple[FixedMesh | FixedPrimitive, ...]
) -> CellConfig:
    """The real cell's configuration from the run's noise section."""
    return CellConfig(
        seed=seed,
        arm=ArmErrors(noise.arm_length_sigma_m, noise.arm_offset_sigma_rad),
        encoder=EncoderNoise(noise.encoder_sigma_rad),
        table=TableErrors(noise.table_bias_sigma_m, noise.table_repeat_sigma_m),
        laser=LaserConfig(sigma_m=noise.laser_sigma_m),
        fixtures=fixtures,
    )


def voxel_thin(points: np.ndarray, voxel_m: float) -> np.ndarray:
    """Indices (K,) of the first point of `points` (N, 3) in each occupied cube of side
    `voxel_m` [m] (every index if voxel_m is 0)."""
    if voxel_m <= 0.0:
        return np.arange(len(points))
    keys = np.floor(points / voxel_m).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def localize(
    points_table: np.ndarray,
    shape: MeshModel,
    max_points: int,
    acceptance: Acceptance,
    seed: int,
    voxel_m: float = 0.0,
    mode: str = "local",
    T_table_object_prior: np.ndarray | None = None,
    pass_labels: np.ndarray | None = None,
    pass_sigma_m: float | None = None,
) -> Localization:
    """Match the object points (N, 3) in the table frame to the virtual model: thinned to
    one point per `voxel_m` cube, then a seeded subsample of at most `max_points`. Mode
    "local" searches without prior; "refine" starts from `T_table_object_prior` (4, 4).
    With the scan pass of each point `pass_labels` (N,) and the arm's accuracy
    `pass_sigma_m` [m] (a pass's rigid offset, per axis), the predicted TRE includes it."""
    rng = np.random.default_rng(seed)
    index = voxel_thin(points_table, voxel_m)
    if len(index) > max_points:
        index = index[np.sort(rng.choice(len(index), max_points, replace=False))]
    used = points_table[index]
    passes = None
    if pass_labels is not None and pass_sigma_m is not None:
        passes = ScanPasses(np.asarray(pass_labels)[index], pass_sigma_m)
    T_init = None if T_table_object_prior is None else invert(T_table_object_prior)
    result = match(
        used,
        shape,
        mode=mode,  # type: ignore[arg-type]
        T_init=T_init,
        acceptance=acceptance,
        passes=passes,
    )
    return Localization(invert(result.T_model_data), result, used, len(points_table))


def run_skull(
    config: SkullConfig,
    folder: Path,
    progress: Progress | None = None,
    recording: Any | None = None,
) -> dict[str, Any]:
    """Run the skull job; returns the results (see scenarios.results for the keys)."""
    from scenarios import outputs
    from scenarios.results import skull_results

    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    timings: dict[str, float] = {}

    t0 = time.perf_counter()
    say(f"model {config.model!r}: virtual and real entity")
    virtual, real = virtual_and_real(config)
    name = "object"
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 5]))
    T_table_nominal = nominal_pose(config.placement, virtual.mesh.vertices)
    T_table_true = draw_true_pose(config.placement, real.mesh.vertices, rng)
    fixture = FixedMesh(
        name,
        real.mesh.vertices,
        real.mesh.faces,
        T_table_true,
        convex_pieces=tuple(p.vertices for p in real.convex_pieces),
    )
    fixtures: tuple[FixedMesh | FixedPrimitive, ...] = (fixture,)
    if config.calibration.enabled:
        box = ObjectBox.of(virtual.mesh.vertices, T_table_nominal)
        check_artifact_clearance(box, config.placement.range_xy_m + 0.03)
        fixtures += artifact_fixtures(config.seed)
    controller, truth = make_real_cell(cell_config(config.noise, config.seed, fixtures))
    evaluator = Evaluator(truth, real, name)
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    timings["setup"] = time.perf_counter() - t0
    log = CellLog(recording, controller, evaluator)
    if recording is not None:
        recording.log_cell_geometry(evaluator.mujoco_model)
        recording.log_model(virtual, T_table_nominal)
    log.bodies()

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
    box = ObjectBox.of(virtual.mesh.vertices, T_table_nominal)
    plan = plan_scan(controller.kinematics, box, config.scan, controller.read_joints())
    say(f"scan plan: {len(plan)} passes at table positions {[p.table_position_m for p in plan]}")
    scan: ScanData = execute_scan(controller, plan, config.scan, say)
    keep = crop_to_object(scan.points_table, box, config.placement.range_xy_m + 0.03)
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
        )
        reason = located.result.reason
    timings["register"] = time.perf_counter() - t0
    targets_model = np.array([h.p_entry for h in virtual.burr_holes])
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
    predicted = located.result.predicted_tre(targets_model) if located is not None else None
    if program is not None:
        outputs.write_program(folder / "program.mod", program, virtual, T_table_nominal)
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
