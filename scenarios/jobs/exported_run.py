"""A job's exported RAPID program run on its real cell as an ABB IRC5 without absolute accuracy
would run it, and measured against the truth: the touches of the job's targets (the writer's
p<Name>Touch robtargets, or a user program's own touch robtargets) against the targets' true
positions. `twincell execute` (scenarios.jobs.execute_run_folder) runs it on a cell rebuilt
from a run folder; the pipeline runs it at the end of a job on the job's own cell.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from cattrs.gen import override

from models.model import ObjectModel
from models.robot import TOOLS
from scenarios.configuration.job_config import JobConfig
from scenarios.offline.operations import UserProgram
from scenarios.rapid.execution_plan import ExecutionPlan
from scenarios.rapid.executor import ExecutedMove, ExecutionRecord, execute_plan
from scenarios.rapid.module import RapidModule
from scenarios.rapid.planner import cell_tools, plan_execution
from scenarios.rapid.rapid_text import rapid_identifier
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import RapidTask, read_task
from scenarios.realcell.setup import JobCell
from scenarios.results.evaluations import TargetEvaluation
from scenarios.results.exported_result import ExportedRun, TargetError
from scenarios.results.json_converter import register_writer, unstructure

Progress = Callable[[str], None]

#: The file the execution's figures go to in the run folder.
EXECUTION_FILE = "execution.json"
#: The evaluator records the executed touches under this prefix, apart from the job's own.
_PREFIX = "execute:"
_READER_LINE = re.compile(r"^(?P<source>.+?), line (?P<line>\d+): ", re.S)


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

    def summary(self) -> ExportedRun:
        """The figures results.json holds under `exported_program`."""
        return ExportedRun(
            "complete",
            program=self.program,
            compensation=self.compensation,
            target_error_rms_m=self.rms_m,
            target_error_max_m=self.max_m,
            targets=tuple(
                TargetError(t.evaluation.name, t.evaluation.error_m) for t in self.targets
            ),
        )


register_writer(
    TouchedTarget,
    keys="name robtarget line error_m axis_error_deg depth_error_m registration_error_m "
    "p_true_base_m p_achieved_base_m p_commanded_base_m p_controller_base_m q_measured_rad",
    derived=lambda t: unstructure(t.evaluation),
    evaluation=override(omit=True),
    p_commanded_base=override(rename="p_commanded_base_m"),
    p_controller_base=override(rename="p_controller_base_m"),
    q_measured=override(rename="q_measured_rad"),
)
#: execution.json: the executed program against the truth, run by a controller without
#: absolute accuracy (nominal kinematics).
register_writer(
    ExecutionResult,
    keys="status program program_path compensation controller job seed tool table_position_m "
    "target_error_rms_m target_error_max_m targets other_stops job_target_error_rms_m "
    "job_target_error_max_m moves skipped motion_time_s wall_time_s",
    derived=lambda r: {
        "status": "complete",
        "controller": {"absolute_accuracy": False, "kinematics": "nominal"},
        "target_error_rms_m": r.rms_m,
        "target_error_max_m": r.max_m,
    },
    source=override(rename="program_path"),
    timings=override(rename="wall_time_s"),
)


def _fold(name: str) -> str:
    return re.sub(r"\s", "", name).casefold()


# -- the job: its targets and its real cell ------------------------------------------------------
def job_targets(config: JobConfig, virtual: ObjectModel, user: UserProgram | None) -> JobTargets:
    """The job's targets and the robtargets that stand for them: the writer's p<Name>Touch
    (scenarios.rapid.writer; with a method's prefix when the job ran each method), or a
    user program's own touch robtargets (the touch is the target: no offset), standing for
    the targets operations.names calls them."""
    names: dict[str, str] = {}
    prefixes = [""]
    if config.operations.per_method:
        prefixes += [f"{method}:" for method in config.localization.methods]
    for hole in virtual.burr_holes:
        names[_fold(hole.name)] = hole.name
        for prefix in prefixes:
            names[_fold(f"{rapid_identifier(prefix + hole.name, 'p')}Touch"[:32])] = hole.name
    if user is not None:  # its touch robtargets stand for the targets they are named
        names.update(
            (_fold(op.name), name) for op, name in zip(user.operations, user.names, strict=True)
        )
    offset = 0.0 if user is not None else config.operations.touch_offset_m
    return JobTargets(virtual, offset, names)


def read_program(path: Path) -> RapidModule | RapidTask:
    """Read a RAPID module, or a task from a folder of modules; its errors say
    `<file>:<line>: <what>` (the reader's own say `<file>, line <line>: <what>`)."""
    try:
        return read_task([path]) if path.is_dir() else read_module(path)
    except RapidError as exc:
        message = _READER_LINE.sub(r"\g<source>:\g<line>: ", str(exc), count=1)
        raise RapidError(message) from None


def nominal_tools() -> dict[str, np.ndarray]:
    """The cell's tools and their nominal TCPs (what `cell_tools` reads from a controller)."""
    return {t.name: np.array(t.T_tool_tcp) for t in TOOLS}


# -- execution -------------------------------------------------------------------------------------
def execute_in_cell(
    cell: JobCell,
    program: RapidModule | RapidTask | ExecutionPlan,
    targets: JobTargets,
    progress: Progress | None = None,
    refetch: bool = False,
) -> ExecutionResult:
    """Run `program` (a module, planned here on the controller's nominal arm from its home,
    or a plan made so) in an already built job cell, the controller moving its nominal arm
    for the time of the program (an absolute-accuracy option it has is set back after), and
    measure the touched job `targets` with the cell's evaluator. A pipeline can call this
    at the end of a job: with `refetch` the tool in hand goes back to its rack first, so that
    the controller fetches it itself, as it would at the program's start. Raises RapidError
    (nothing moved) for a program that cannot run."""
    say = progress or (lambda _msg: None)
    controller = cell.controller
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
    previous = controller.absolute_accuracy
    controller.set_absolute_accuracy(None)
    if refetch and controller.tool_in_hand is not None:
        controller.move_joints(controller.q_home)
        controller.return_tool()

    def at_touch(robtarget: str) -> None:
        record_touch(cell, targets, robtarget, plan.tool)

    t0 = time.perf_counter()
    try:
        record = execute_plan(controller, plan, at_touch, cell.log.moved)
    finally:
        controller.set_absolute_accuracy(previous)
    timings["execute"] = time.perf_counter() - t0
    result = measure_execution(cell, record, targets, timings)
    say(
        f"executed {result.moves} moves in {result.motion_time_s:.1f} s of the controller's "
        f"clock; {len(result.targets)} job targets touched"
    )
    return result


def record_touch(cell: JobCell, targets: JobTargets, robtarget: str, tool: str | None) -> None:
    """The evaluator's record of a touch of `robtarget` with `tool` in hand, if it stands
    for one of the job's targets (what `measure_execution` measures)."""
    name = targets.name_of(robtarget)
    if name is not None and tool is not None:
        cell.touches.record_touch(_PREFIX + name, tool)


def measure_execution(
    cell: JobCell,
    record: ExecutionRecord,
    targets: JobTargets,
    timings: dict[str, float] | None = None,
) -> ExecutionResult:
    """The result of an executed program: its touches of the job's targets (recorded with
    `record_touch` as they happened) against the truth."""
    plan = record.plan
    measured = _measure(record, targets, cell)
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
        record.end_time_s - record.start_time_s,
        dict(timings or {}),
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
            for e in cell.touches.targets(
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
