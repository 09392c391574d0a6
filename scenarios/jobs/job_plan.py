"""A job in its virtual cell, before the real one is built (`plan_job`): its planning
settings, its arm, the user's program, the object's virtual model (and the real entity the
real cell's set-up will place), whether the arm reaches what the job needs, and the scan's
passes. A job that cannot be done refuses here, before anything moves."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from itertools import islice

import numpy as np

from cell import nominal_T_base_table
from cell.cell_errors import CellConfigError
from cell.robot_arm import Robot
from cell.robots import BUILTIN, make_robot
from models.cache import enabled as cache_enabled
from models.cache import used_key
from models.ct.readers import is_volume
from models.model import ObjectModel
from models.registry import real_model
from scenarios.configuration.cell_sections import RobotSection
from scenarios.configuration.job_config import JobConfig
from scenarios.offline.arm_setup import (
    ArmSetupError,
    arm_setups,
    joint_window,
    no_home_message,
)
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.nominal_placement import nominal_pose, upright_rotation
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
from scenarios.offline.plan_cache import cached_plan, plan_key
from scenarios.offline.reach import check_reach
from scenarios.offline.reach_proposal import reach_proposal
from scenarios.offline.scan_candidates import ScanPlanError
from scenarios.offline.scan_passes import ObjectBox
from scenarios.offline.scan_plan import ScanPlan
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.table_candidates import UnreachablePlanError
from scenarios.program.program_types import Operation
from scenarios.realcell.ct import ct_virtual_model
from scenarios.realcell.setup import model_error
from scenarios.scenario_errors import ScenarioError
from scenarios.stages.scan_stage import job_scan_plan, plan_summary

Progress = Callable[[str], None]


def object_models(
    config: JobConfig, user: UserProgram | None = None, use_cache: bool = True
) -> tuple[ObjectModel, ObjectModel]:
    """The job's object: its virtual model with the operations' targets (from the model, or
    the touches of the user's program; what the planner knows) and its real entity (the
    model error drawn from the seed, or with `model.source: ct` the design itself, the
    virtual model being meshed from its simulated CT: the truth). `use_cache`: a built-in
    model may be read from the user's cache folder (models.cache)."""
    obj = config.cell.object
    virtual = virtual_model(
        obj.model,
        obj.units,
        obj.targets_file,
        config.operations.kind,
        config.seed,
        config.model.ct.iso_hu,
        config.model.ct.resample_mm,
        config.model.ct.max_gap_mm,
        use_cache,
        up_model=upright_rotation(obj.placement)[2],  # the table's vertical, as the part lies
    )
    if user is not None:
        virtual = replace(virtual, burr_holes=program_targets(user))
    if config.model.source == "ct":  # the design is the real object; the model is its CT's
        return ct_virtual_model(virtual, config.model.ct, config.seed), virtual
    real, _ = real_model(virtual, model_error(config.cell.noise), seed=config.seed)
    return virtual, real


def job_robot(
    section: RobotSection,
    home: np.ndarray | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
) -> Robot:
    """The cell's arm as the job's configuration names it (cell.robots); `home` [rad] and
    `limits` (lower, upper) [rad] where the section gives none (a file arm's chosen ones)."""
    if section.home_deg is not None:
        home = np.deg2rad(section.home_deg)
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


#: How many of a file arm's chosen homes (one per branch) a job tries before it refuses.
ARM_SETUPS_TRIED = 4


def job_arms(
    config: JobConfig, virtual: ObjectModel, T_table_nominal: np.ndarray, say: Progress
) -> Iterator[Robot]:
    """The job's arm: the one its cell gives (a built-in arm, or a file arm with home and
    joint window); for a file arm without them, the homes and windows chosen in the virtual
    cell (scenarios.offline.arm_setup), best first, each said as it is tried."""
    section = config.cell.robot
    robot = job_robot(section)
    if section.model in BUILTIN:
        yield robot
        return
    file_speed = robot.kinematics().model.velocityLimit
    if section.speed_deg_s is None and not (np.isfinite(file_speed) & (file_speed > 0)).all():
        speeds = ", ".join(f"{v:.0f}" for v in np.rad2deg(robot.joint_speed))
        say(
            f"arm: {section.model} gives no joint speed limits; assumed [{speeds}] deg/s "
            "(cell.robot.speed_deg_s gives the arm's own)"
        )
    if section.home_deg is not None and section.limits_deg is not None:
        yield robot
        return
    calibrates = config.calibration.enabled  # its spheres on the table
    cell = job_virtual_cell(robot, config.cell.rack_xyz, virtual, T_table_nominal, calibrates)
    if section.home_deg is not None:  # the window around the given home
        try:
            lower, upper, _ = joint_window(robot.kinematics(), robot.q_home, cell)
        except ArmSetupError as exc:
            raise ScenarioError(f"cell.robot: {exc}") from None
        say("arm: joint window chosen around the given home (cell.robot.limits_deg to fix it)")
        yield job_robot(section, None, (lower, upper))
        return
    box = ObjectBox.of(virtual.mesh.vertices, T_table_nominal)
    T_world_table = nominal_T_base_table(0.0)
    centre = T_world_table[:3, :3] @ box.centre + T_world_table[:3, 3]
    setups = arm_setups(robot.kinematics(), cell, centre, float(centre[2] + box.half[2]))
    found = False
    for setup in islice(setups, ARM_SETUPS_TRIED):
        found = True
        say(f"arm: {setup.describe()} (cell.robot.home_deg, cell.robot.limits_deg to fix them)")
        window = None if section.limits_deg else (setup.lower, setup.upper)
        yield job_robot(section, setup.q_home, window)
    if not found:
        raise ScenarioError(f"cell.robot: {no_home_message()}")


def file_arm(
    config: JobConfig, virtual: ObjectModel, T_table_nominal: np.ndarray, say: Progress
) -> Robot:
    """The job's arm, or a file arm's best chosen home and window (see `job_arms`)."""
    return next(job_arms(config, virtual, T_table_nominal, say))


@dataclass(frozen=True, eq=False)
class JobPlan:
    """What a job is before its real cell is built: its planning settings, its arm, the
    user's program (if any), the virtual model and the real entity (the truth: for the real
    cell's set-up only), the nominal pose T_table_object (4, 4), the scan plan, and the
    keys the scan plan and the model were cached under (None: the cache is off, the job does
    not scan, the model is not one the cache holds)."""

    settings: PlanningSettings
    robot: Robot
    user: UserProgram | None
    virtual: ObjectModel
    real: ObjectModel
    T_table_nominal: np.ndarray
    scan_plan: ScanPlan | None
    plan_cache: str | None = None
    model_cache: str | None = None


def plan_job(config: JobConfig, say: Progress, use_cache: bool = True) -> JobPlan:
    """The job in its virtual cell, before the real one: the models, whether the arm reaches
    the rack slots, the scan and the operations, and the scan's passes (chosen, or for a
    fixed plan predicted): a job that cannot be done refuses here. `use_cache`: the skull
    phantom and the scan plan may be read from and written to the user's cache folder
    (models.cache, scenarios.offline.plan_cache)."""
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
    virtual, real = object_models(config, user, use_cache)
    if is_volume(obj.model):  # what was read, and how its slices were regularised
        say(f"model: {virtual.source}")
    T_table_nominal = nominal_pose(settings.placement, virtual.mesh.vertices)
    if user is not None:
        check_program_frame(user, nominal_T_base_table(user.table_position_m) @ T_table_nominal)
        say(f"program {config.operations.program}: {len(user.operations)} touches")
    # Can this arm do this job here at all? Asked of the virtual cell, before the real one.
    operations = (
        target_operations(virtual, config.operations) if user is None else program_operations(user)
    )
    arms = job_arms(config, virtual, T_table_nominal, say)
    robot = next(arms)
    while True:
        try:
            scan_plan, plan_cache = _arm_plan(config, robot, user, virtual, T_table_nominal,
                                              operations, say, use_cache)  # fmt: skip
            break
        except UnreachablePlanError as exc:
            say(f"arm: that home does not do this job: {exc}")
            robot_next = next(arms, None)
            if robot_next is None:
                raise _with_proposal(exc, config, robot, user, virtual, operations) from None
            robot = robot_next
    model_cache = used_key(obj.model, config.seed, use_cache)
    return JobPlan(settings, robot, user, virtual, real, T_table_nominal, scan_plan, plan_cache,
                   model_cache)  # fmt: skip


def _arm_plan(
    config: JobConfig,
    robot: Robot,
    user: UserProgram | None,
    virtual: ObjectModel,
    T_table_nominal: np.ndarray,
    operations: tuple[Operation, ...],
    say: Progress,
    use_cache: bool = True,
) -> tuple[ScanPlan | None, str | None]:
    """Whether `robot` reaches the job's rack slots, scan and operations, and its scan plan
    and the plan's cache key (None, None without a surface scan; a key None with the cache
    off: `use_cache`); raises UnreachablePlanError naming what it cannot do."""
    settings = config.planning()
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
    if "surface" not in config.localization.methods:
        return None, None
    # The scan's passes, chosen (or, for a fixed plan, predicted) in the virtual cell
    # before the real one moves: a target no pass constrains refuses the job here.
    targets = np.array([op.T_object_touch[:3, 3] for op in operations])
    names = tuple(op.name for op in operations)
    key = plan_key(robot, settings, virtual, T_table_nominal, targets, names)
    scan_plan, stored = cached_plan(
        key,
        lambda: job_scan_plan(robot, settings, virtual, T_table_nominal, targets, say, names),
        use_cache,
    )
    if stored:
        say(f"scan plan: this virtual cell's plan, from the cache ({key})")
        say(plan_summary(scan_plan))
    return scan_plan, key if cache_enabled(use_cache) else None


def _with_proposal(
    refusal: UnreachablePlanError,
    config: JobConfig,
    robot: Robot,
    user: UserProgram | None,
    virtual: ObjectModel,
    operations: tuple[Operation, ...],
) -> UnreachablePlanError:
    """The reach refusal with the change the virtual cell checked that lets `robot` do the
    job (scenarios.offline.reach_proposal), where there is one. A scan plan's own refusal
    is kept as it is: it names its keys itself."""
    if isinstance(refusal, ScanPlanError):
        return refusal
    pick = (
        None if config.operations.pick is None else grasp_operation(virtual, config.operations.pick)
    )
    table = None if user is None else (user.table_position_m,)
    change = reach_proposal(robot, config.planning(), virtual, operations, pick, table)
    if change is None:
        return refusal
    return UnreachablePlanError(
        f"{refusal}; proposed: --set {change} (with it the virtual cell's arm reaches the "
        "rack, the scan and the operations)"
    )
