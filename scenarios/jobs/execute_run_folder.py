"""`twincell execute RUN_FOLDER`: run the RAPID program a run exported on that run's real
cell, as an ABB IRC5 controller without the absolute-accuracy option runs it, and measure
how close the touched targets come to the true ones.

The run folder's config.yaml rebuilds the job's real cell exactly as `twincell run` built it
(the same seed: the same real arm, the same true placement of the object), with the
controller moving its nominal arm: no calibration and no absolute accuracy, the arm's
kinematics as its data sheet gives them. The program (program.mod, or `--program`) is planned
on that nominal arm before the cell is built (scenarios.rapid.planner): a program that
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
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cell.robot_arm import Robot
from models.atomic import write_text
from models.model import ObjectModel
from scenarios.configuration.config_files import load_config
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.exported_run import (
    EXECUTION_FILE,
    ExecutionResult,
    execute_in_cell,
    job_targets,
    nominal_tools,
    read_program,
)
from scenarios.jobs.job_plan import job_robot, object_models
from scenarios.jobs.pipeline import job_cell
from scenarios.offline.operations import UserProgram, read_user_program
from scenarios.rapid.planner import plan_execution
from scenarios.realcell.setup import JobCell
from scenarios.results.json_converter import unstructure
from scenarios.results.results_file import read_results
from scenarios.results.run import RunNotEndedError
from scenarios.scenario_errors import ScenarioError
from scenarios.stages.export_stage import TASK_FOLDER

Progress = Callable[[str], None]


class RunFolderError(ScenarioError, FileNotFoundError):
    """A folder that is not a run folder of `twincell run`, or that holds no program."""


def job_program(config: JobConfig, folder: Path) -> UserProgram | None:
    """The user's program a job was run with (None for a job on the model's targets): its
    file as the configuration names it or, if that file is gone, the module the run wrote
    back (program.mod: its work object's oframe corrected and, if it was written filtered,
    its touches' robtargets too: the targets are then read off by the arm's error that the
    filtering took out)."""
    section = config.operations
    if section.program is None:
        return None
    path = Path(section.program)
    if not path.exists():
        path = _written_program(folder)
    return read_user_program(section.model_copy(update={"program": str(path)}))


def rebuild_job_cell(
    config: JobConfig, virtual: ObjectModel, real: ObjectModel, robot: Robot
) -> JobCell:
    """The job's real cell as `run_cell_job` builds it (the same arguments: the seed's real
    arm and errors, the true placement from the same random stream, the calibration spheres
    if the job calibrated), without a recording; its controller moves the nominal arm."""
    return job_cell(config, virtual, real, robot)


def _written_program(folder: Path) -> Path:
    """The program a run wrote: program.mod, or the folder of a user's task of modules."""
    module, task = folder / "program.mod", folder / TASK_FOLDER
    return task if task.is_dir() and not module.exists() else module


# -- the program -----------------------------------------------------------------------------------
def execute_run(
    folder: str | Path, program: str | Path | None = None, progress: Progress | None = None
) -> ExecutionResult:
    """Execute a run folder's program (program.mod or its task folder, or `program`: a module
    file or a folder of modules) on its job's real cell with
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
    module_file = Path(program) if program is not None else _written_program(folder)
    if not module_file.exists():
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
        module, robot.kinematics(), nominal_tools(), robot.q_home, robot.joint_speed
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
    job_rms, job_max, exported_compensation = _job_figures(folder)
    timings["total"] = time.perf_counter() - t_total
    result = ExecutionResult(
        module_file.name,
        str(module_file),
        # The run's own program: the compensation the export wrote it with (a user's module
        # written back filtered states none in its text).
        (program is None and exported_compensation) or executed.compensation,
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
    write_text(folder / EXECUTION_FILE, json.dumps(unstructure(result), indent=2) + "\n")
    return result


def _job_figures(folder: Path) -> tuple[float | None, float | None, str]:
    """The run's own target errors (rms, max) [m] from its results.json, and the compensation
    its exported program was written with; None (and "") where it has none (no results.json,
    a run that was refused or did not complete, an exported program not run)."""
    path = folder / "results.json"
    if not path.is_file():
        return None, None, ""
    try:
        result = read_results(path)
    except RunNotEndedError:
        return None, None, ""
    exported = result.exported_program
    compensation = "" if exported is None else exported.compensation
    return result.target_error_rms_m, result.target_error_max_m, compensation


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
