"""`twincell execute RUN_FOLDER`: run the RAPID program a run exported on that run's real
cell, as an ABB IRC5 controller without the absolute-accuracy option runs it, and measure
how close the touched targets come to the true ones.

The run folder's config.yaml rebuilds the job's real cell exactly as `twincell run` built it
(the same seed: the same real arm, the same true placement of the object), with the
controller moving its nominal arm: no calibration and no absolute accuracy, the arm's
kinematics as its data sheet gives them. The program (program.mod, or `--program`) is planned
on that nominal arm before the cell is built (scenarios.offline.rapid_exec): a program that
cannot run is refused without any motion. Then it runs, and at each touch (a MoveL to a stop
point) the evaluator records the truth; a touch whose robtarget stands for one of the job's
targets (the writer's p<Name>Touch, or a user program's own touch robtarget) is measured
against that target's true position. The figures go to execution.json in the run folder,
beside the run's own results.json: the run reports the accuracy of its own execution (with
the arm it calibrated), this one what a controller without that calibration achieves with the
same program.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.robots import Robot
from models import ObjectModel
from models.atomic import write_text
from models.robot import TOOLS
from scenarios.errors import ScenarioError
from scenarios.jobs.config import JobConfig, load_config
from scenarios.jobs.pipeline import job_robot, object_models
from scenarios.offline.operations import UserProgram, read_user_program
from scenarios.offline.rapid import _identifier
from scenarios.offline.rapid_exec import (
    ExecutedMove,
    ExecutionPlan,
    ExecutionRecord,
    cell_tools,
    execute_plan,
    plan_execution,
)
from scenarios.offline.rapid_module import RapidError, RapidModule, read_module
from scenarios.realcell.evaluation import TargetEvaluation
from scenarios.realcell.setup import JobCell, build_job_cell

Progress = Callable[[str], None]

#: The file `execute_run` writes into the run folder.
EXECUTION_FILE = "execution.json"
#: The evaluator records the executed touches under this prefix, apart from the job's own.
_PREFIX = "execute:"
_READER_LINE = re.compile(r"^(?P<source>.+?), line (?P<line>\d+): ", re.S)


class RunFolderError(ScenarioError, FileNotFoundError):
    """A folder that is not a run folder of `twincell run`, or that holds no program."""


@dataclass(frozen=True, eq=False)
class JobTargets:
    """The job's targets as the evaluator knows them: the virtual model that holds them, the
    touch offset before each entry [m], and the robtarget names (case and blanks folded)
    that stand for them -> the target's name."""

    virtual: ObjectModel
    touch_offset_m: float
    names: dict[str, str]

    def name_of(self, robtarget: str) -> str | None:
        """The job target a touched robtarget (as written) stands for, or None."""
        return self.names.get(_fold(robtarget))


@dataclass(frozen=True, eq=False)
class TouchedTarget:
    """A job target as the program touched it: the evaluator's measure against the truth
    (error_m, the achieved and true points), the robtarget and its line, the TCP the program
    commanded p_commanded_base (3,) [m], the encoders then q_measured (6,) [rad] and the TCP
    they give with the controller's nominal kinematics p_controller_base (3,) [m] (where the
    controller believes the TCP is)."""

    evaluation: TargetEvaluation
    robtarget: str
    line: int
    p_commanded_base: np.ndarray
    q_measured: np.ndarray
    p_controller_base: np.ndarray


@dataclass(frozen=True, eq=False)
class ExecutionResult:
    """An executed program against the truth.

    Attributes:
        program: the module's file name; source: its path (or the module's name).
        compensation: what the module states of its targets ("nominal" if nothing).
        tool: the cell's tool the program ran with (None: the flange only).
        table_position_m: the table at the last move (None: never set by the program).
        targets: the touched job targets, in the order of their (last) touch.
        other_stops: touched robtargets that stand for no job target.
        moves, skipped: moves run, and instructions run without effect ("line N: Name").
        motion_time_s: the controller's clock over the execution, tool change included [s].
        timings: wall time per step [s].
        job, seed: the run's job and seed; job_target_error_rms_m, job_target_error_max_m:
            the run's own figures (results.json; None if absent).
    """

    program: str
    source: str
    compensation: str
    tool: str | None
    table_position_m: float | None
    targets: tuple[TouchedTarget, ...]
    other_stops: tuple[str, ...]
    moves: int
    skipped: tuple[str, ...]
    motion_time_s: float
    timings: dict[str, float] = field(default_factory=dict)
    job: str = ""
    seed: int = 0
    job_target_error_rms_m: float | None = None
    job_target_error_max_m: float | None = None

    def errors(self) -> np.ndarray:
        """(K,) the touched targets' errors [m]."""
        return np.array([t.evaluation.error_m for t in self.targets])

    @property
    def rms_m(self) -> float | None:
        e = self.errors()
        return float(np.sqrt(np.mean(e**2))) if len(e) else None

    @property
    def max_m(self) -> float | None:
        e = self.errors()
        return float(e.max()) if len(e) else None

    def to_json(self) -> dict[str, Any]:
        """The execution.json mapping (plain numbers and lists)."""
        return {
            "status": "complete",
            "program": self.program,
            "program_path": self.source,
            "compensation": self.compensation,
            "controller": {"absolute_accuracy": False, "kinematics": "nominal"},
            "job": self.job,
            "seed": self.seed,
            "tool": self.tool,
            "table_position_m": self.table_position_m,
            "target_error_rms_m": self.rms_m,
            "target_error_max_m": self.max_m,
            "targets": [
                {
                    "name": t.evaluation.name,
                    "robtarget": t.robtarget,
                    "line": t.line,
                    "error_m": t.evaluation.error_m,
                    "axis_error_deg": t.evaluation.axis_error_deg,
                    "registration_error_m": t.evaluation.registration_error_m,
                    "p_true_base_m": t.evaluation.p_true_base.tolist(),
                    "p_achieved_base_m": t.evaluation.p_achieved_base.tolist(),
                    "p_commanded_base_m": t.p_commanded_base.tolist(),
                    "p_controller_base_m": t.p_controller_base.tolist(),
                    "q_measured_rad": t.q_measured.tolist(),
                }
                for t in self.targets
            ],
            "other_stops": list(self.other_stops),
            "job_target_error_rms_m": self.job_target_error_rms_m,
            "job_target_error_max_m": self.job_target_error_max_m,
            "moves": self.moves,
            "skipped": list(self.skipped),
            "motion_time_s": self.motion_time_s,
            "wall_time_s": dict(self.timings),
        }


def _fold(name: str) -> str:
    return re.sub(r"\s", "", name).casefold()


# -- the job: its targets and its real cell ------------------------------------------------------
def job_program(config: JobConfig, folder: Path) -> UserProgram | None:
    """The user's program a job was run with (None for a job on the model's targets): its
    file as the configuration names it or, if that file is gone, the module the run wrote
    back (program.mod: only its work object's oframe differs, not its targets)."""
    section = config.operations
    if section.program is None:
        return None
    path = Path(section.program)
    if not path.is_file():
        path = folder / "program.mod"
    return read_user_program(section.model_copy(update={"program": str(path)}))


def job_targets(config: JobConfig, virtual: ObjectModel, user: UserProgram | None) -> JobTargets:
    """The job's targets and the robtargets that stand for them: the writer's p<Name>Touch
    (scenarios.offline.rapid; with a method's prefix when the job ran each method), or a
    user program's own touch robtargets (the touch is the target: no offset)."""
    names: dict[str, str] = {}
    prefixes = [""]
    if config.operations.per_method:
        prefixes += [f"{method}:" for method in config.localization.methods]
    for hole in virtual.burr_holes:
        names[_fold(hole.name)] = hole.name
        for prefix in prefixes:
            names[_fold(f"{_identifier(prefix + hole.name, 'p')}Touch"[:32])] = hole.name
    offset = 0.0 if user is not None else config.operations.touch_offset_m
    return JobTargets(virtual, offset, names)


def rebuild_job_cell(
    config: JobConfig, virtual: ObjectModel, real: ObjectModel, robot: Robot
) -> JobCell:
    """The job's real cell as `run_cell_job` builds it (the same arguments: the seed's real
    arm and errors, the true placement from the same random stream, the calibration spheres
    if the job calibrated), without a recording; its controller moves the nominal arm."""
    obj = config.cell.object
    loose = obj.fixing == "loose"
    return build_job_cell(
        virtual,
        real,
        obj.placement,
        config.cell.noise,
        config.calibration,
        config.seed,
        stream=6 if loose else 5,
        crop_margin_m=config.localization.scan.crop_margin_m,
        recording=None,
        name="part" if loose else "object",
        loose=loose,
        rgba=(0.7, 0.72, 0.78, 1.0) if loose else (0.9, 0.85, 0.75, 1.0),
        robot=robot,
        rack_xyz=config.cell.rack_xyz,
    )


# -- the program -----------------------------------------------------------------------------------
def read_program(path: Path) -> RapidModule:
    """Read a RAPID module; its errors say `<file>:<line>: <what>` (the reader's own say
    `<file>, line <line>: <what>`)."""
    try:
        return read_module(path)
    except RapidError as exc:
        message = _READER_LINE.sub(r"\g<source>:\g<line>: ", str(exc), count=1)
        raise RapidError(message) from None


def _nominal_tools() -> dict[str, np.ndarray]:
    """The cell's tools and their nominal TCPs (what `cell_tools` reads from a controller)."""
    return {t.name: np.array(t.T_tool_tcp) for t in TOOLS}


# -- execution -------------------------------------------------------------------------------------
def execute_in_cell(
    cell: JobCell,
    program: RapidModule | ExecutionPlan,
    targets: JobTargets,
    progress: Progress | None = None,
) -> ExecutionResult:
    """Run `program` (a module, planned here on the controller's nominal arm from its home,
    or a plan made so) in an already built job cell, the controller moving its nominal arm
    for the time of the program (an absolute-accuracy option it has is set back after), and
    measure the touched job `targets` with the cell's evaluator. A pipeline can call this
    at the end of a job; then the tool in hand sits where the job's own tool change left it.
    Raises RapidError (nothing moved) for a program that cannot run."""
    say = progress or (lambda _msg: None)
    controller, evaluator = cell.controller, cell.evaluator
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if isinstance(program, ExecutionPlan):
        plan = program
    else:
        plan = plan_execution(
            program,
            controller.nominal_kinematics,
            cell_tools(controller),
            controller.q_home,
            controller.robot.joint_speed,
        )
        timings["plan"] = time.perf_counter() - t0
    previous = controller.kinematics
    controller.set_absolute_accuracy(None)

    def at_touch(robtarget: str) -> None:
        name = targets.name_of(robtarget)
        if name is not None and plan.tool is not None:
            evaluator.record_touch(_PREFIX + name, plan.tool)

    t0 = time.perf_counter()
    try:
        record = execute_plan(controller, plan, at_touch, cell.log.moved)
    finally:
        restored = None if previous is controller.nominal_kinematics else previous
        controller.set_absolute_accuracy(restored)
    timings["execute"] = time.perf_counter() - t0
    measured = _measure(record, targets, cell)
    motion_s = record.end_time_s - record.start_time_s
    say(
        f"executed {len(record.moves)} moves in {motion_s:.1f} s of the controller's clock; "
        f"{len(measured.targets)} job targets touched"
    )
    return ExecutionResult(
        Path(plan.source).name,
        plan.source,
        plan.compensation,
        plan.tool,
        measured.table_position_m,
        measured.targets,
        measured.other_stops,
        len(record.moves),
        plan.skipped,
        motion_s,
        timings,
    )


@dataclass(frozen=True, eq=False)
class _Measured:
    targets: tuple[TouchedTarget, ...]
    other_stops: tuple[str, ...]
    table_position_m: float | None


def _measure(record: ExecutionRecord, targets: JobTargets, cell: JobCell) -> _Measured:
    """The touched targets against the truth (the evaluator's records of `execute_in_cell`):
    the last touch of each target, in the order of those touches."""
    last: dict[str, ExecutedMove] = {}
    other: list[str] = []
    for executed in record.touches:
        name = targets.name_of(executed.move.target)
        if name is None or record.plan.tool is None:
            other.append(executed.move.target)
        else:
            last.pop(name, None)
            last[name] = executed
    touched: list[TouchedTarget] = []
    if last:
        # The registration's share of each error: the object frame the program's touches
        # were corrected with (uframe @ oframe of their work object).
        T_base_oframe = next(iter(last.values())).move.T_base_oframe
        evaluations = {
            e.name.removeprefix(_PREFIX): e
            for e in cell.evaluator.targets(
                targets.touch_offset_m, targets.virtual, T_base_oframe, _PREFIX
            )
        }
        for name, executed in last.items():
            move = executed.move
            touched.append(
                TouchedTarget(
                    replace(evaluations[name], name=name),
                    move.target,
                    move.line,
                    move.T_base_tcp[:3, 3].copy(),
                    executed.q_measured,
                    executed.T_base_tcp_measured[:3, 3].copy(),
                )
            )
    tables = [m.move.table_position_m for m in record.moves if m.move.table_position_m is not None]
    return _Measured(tuple(touched), tuple(other), tables[-1] if tables else None)


def execute_run(
    folder: str | Path, program: str | Path | None = None, progress: Progress | None = None
) -> ExecutionResult:
    """Execute a run folder's program (program.mod, or `program`) on its job's real cell with
    the nominal arm (see the module's docstring) and write execution.json into the folder.
    Raises RunFolderError for a folder without config.yaml or without the program, and
    RapidError `<file>:<line>: <what>` for a program that cannot run; in both cases before
    the cell is built."""
    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    timings: dict[str, float] = {}
    folder = Path(folder)
    config_file = folder / "config.yaml"
    if not config_file.is_file():
        raise RunFolderError(
            f"{config_file}: no such file: {folder} is not a run folder of `twincell run` "
            "(each holds the config.yaml of its job)"
        )
    module_file = Path(program) if program is not None else folder / "program.mod"
    if not module_file.is_file():
        why = "" if program is not None else ": the run wrote no RAPID program (see results.json)"
        raise RunFolderError(f"{module_file}: no such file{why}")
    config = load_config(config_file)
    if not isinstance(config, JobConfig):
        raise ScenarioError(f"{config_file}: a {config.kind} job runs no program on a cell")
    robot = job_robot(config.cell.robot)
    if not robot.rapid:
        raise ScenarioError(
            f"{config_file}: the job's arm, the {robot.name}, does not run RAPID "
            f"({robot.vendor or 'vendor unknown'})"
        )

    # Plan on the nominal arm the controller will have (the robot's data sheet), before the
    # real cell exists: a program that cannot run moves nothing.
    t0 = time.perf_counter()
    module = read_program(module_file)
    plan = plan_execution(
        module, robot.kinematics(), _nominal_tools(), robot.q_home, robot.joint_speed
    )
    timings["plan"] = time.perf_counter() - t0
    say(f"{module_file.name}: {len(plan.moves)} moves, {len(plan.touches)} touches planned")

    t0 = time.perf_counter()
    user = job_program(config, folder)
    virtual, real = object_models(config, user)
    cell = rebuild_job_cell(config, virtual, real, robot)
    timings["cell"] = time.perf_counter() - t0
    say(f"the real cell of {config.name} (seed {config.seed}), the arm on nominal kinematics")

    executed = execute_in_cell(cell, plan, job_targets(config, virtual, user), say)
    timings["execute"] = executed.timings["execute"]
    job_rms, job_max = _job_figures(folder)
    timings["total"] = time.perf_counter() - t_total
    result = ExecutionResult(
        module_file.name,
        str(module_file),
        executed.compensation,
        executed.tool,
        executed.table_position_m,
        executed.targets,
        executed.other_stops,
        executed.moves,
        executed.skipped,
        executed.motion_time_s,
        timings,
        config.name,
        config.seed,
        job_rms,
        job_max,
    )
    write_text(folder / EXECUTION_FILE, json.dumps(result.to_json(), indent=2) + "\n")
    return result


def _job_figures(folder: Path) -> tuple[float | None, float | None]:
    """The run's own target errors (rms, max) [m] from its results.json; None where it has
    none (no results.json, a run that was refused or did not complete)."""
    path = folder / "results.json"
    if not path.is_file():
        return None, None
    results = json.loads(path.read_text())
    return results.get("target_error_rms_m"), results.get("target_error_max_m")


def _mm(a: float, b: float) -> str:
    return f"{a * 1e3:.3f} / {b * 1e3:.3f}"


def execution_table(result: ExecutionResult) -> Any:
    """A rich table of the executed program's target errors [mm]."""
    from rich.table import Table
    from rich.text import Text

    table = Table(title=f"{result.program}: nominal arm, compensation {result.compensation}")
    table.add_column("target")
    table.add_column(Text("error [mm]"), justify="right")
    table.add_column(Text("reg. share [mm]"), justify="right")
    table.add_column("robtarget:line")
    for t in result.targets:
        e = t.evaluation
        table.add_row(
            Text(e.name),
            f"{e.error_m * 1e3:.3f}",
            f"{e.registration_error_m * 1e3:.3f}",
            Text(f"{t.robtarget}:{t.line}"),
        )
    if result.rms_m is not None and result.max_m is not None:
        table.add_row(Text("rms / max"), _mm(result.rms_m, result.max_m), "", "")
    own_rms, own_max = result.job_target_error_rms_m, result.job_target_error_max_m
    if own_rms is not None and own_max is not None:
        table.add_row(Text("the run's own"), _mm(own_rms, own_max), "", Text("results.json"))
    for stop in result.other_stops:
        table.add_row(Text("(no target)"), "", "", Text(stop))
    table.add_row(Text("motion [s]"), f"{result.motion_time_s:.1f}", "", Text("controller's clock"))
    return table
