"""`twincell serve JOB_OR_RUN_FOLDER`: a job's real cell behind the controller's own
interfaces, RWS and EGM (scenarios.twin), so that a client written for an ABB IRC5 drives it.

The cell is the one `twincell run` builds for the job and seed (the same real arm, errors
and true placement of the object); a run folder gives that run's cell, and its program is
put in the controller's `$HOME` (program.mod, or the task's modules), ready to load. The
controller moves its nominal arm, as `twincell execute` does. Each program a client runs to
its end is measured against the truth as `twincell execute` measures it, and written to
the serve folder (executions/NNN-<program>.json, the execution.json layout) and to the
controller's $HOME/executions/ (where a client reads it over RWS).
"""

from __future__ import annotations

import json
import shutil
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from models.atomic import write_text
from scenarios.configuration.config_files import load_config
from scenarios.configuration.job_config import JobConfig
from scenarios.irc5.helper_module import HELPER_FILE, helper_text
from scenarios.jobs.execute_run_folder import job_program, rebuild_job_cell
from scenarios.jobs.exported_run import (
    ExecutionResult,
    JobTargets,
    job_targets,
    measure_execution,
    record_touch,
)
from scenarios.jobs.job_plan import job_robot, object_models
from scenarios.jobs.pipeline import job_cell
from scenarios.rapid.executor import ExecutionRecord
from scenarios.realcell.setup import JobCell
from scenarios.results.json_converter import unstructure
from scenarios.scenario_errors import ScenarioError
from scenarios.stages.export_stage import TASK_FOLDER
from scenarios.twin.elog import ElogEntry
from scenarios.twin.server import ServedController, ServeOptions
from scenarios.twin.twin_controller import TwinController

Progress = Callable[[str], None]
#: The folder of the measured programs, in the serve folder and the controller's $HOME.
EXECUTIONS = "executions"


@dataclass
class Serving:
    """A served twin: its controller and servers, the job's real cell (the truth: for the
    evaluator's measures only), the serve folder, and the programs measured so far."""

    served: ServedController
    cell: JobCell
    folder: Path
    config: JobConfig
    executions: list[ExecutionResult] = field(default_factory=list)
    recording: Any | None = None
    changed: threading.Condition = field(default_factory=threading.Condition)

    @property
    def twin(self) -> TwinController:
        return self.served.twin

    @property
    def url(self) -> str:
        return self.served.url

    def wait_executions(self, count: int, timeout_s: float) -> list[ExecutionResult]:
        """The measured programs once there are `count` of them (or after `timeout_s`)."""
        with self.changed:
            self.changed.wait_for(lambda: len(self.executions) >= count, timeout_s)
            return list(self.executions)

    def close(self) -> None:
        self.served.close()
        if self.recording is not None:
            self.recording.close(keep=True)


def serve_folder(out: str | Path, config: JobConfig) -> Path:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    folder = Path(out) / f"serve-{config.name}-seed{config.seed}-{stamp}"
    n = 1
    while folder.exists():
        n += 1
        folder = Path(out) / f"serve-{config.name}-seed{config.seed}-{stamp}-{n}"
    folder.mkdir(parents=True)
    return folder


def _job(
    name: str | Path,
    seed: int | None,
    overrides: dict[str, object] | None = None,
    cell: str | Path | None = None,
) -> tuple[JobConfig, Path | None]:
    """The job's configuration (a shipped job, a CONFIG.yaml or a run folder's, with the
    `cell`, the seed and `overrides` applied) and, for a run folder, the folder."""
    given = Path(name)
    run = given if given.is_dir() else None
    source = given / "config.yaml" if run is not None else name
    if run is not None and not (run / "config.yaml").is_file():
        raise ScenarioError(f"{run}: not a run folder of `twincell run` (no config.yaml)")
    extra: dict[str, object] = dict(overrides or {}) | ({} if seed is None else {"seed": seed})
    config = load_config(source, extra, cell)
    if not isinstance(config, JobConfig):
        raise ScenarioError(f"{name}: a {config.kind} job has no real cell")
    return config, run


def cell_of_job(
    name: str | Path,
    seed: int | None = None,
    overrides: dict[str, object] | None = None,
    cell: str | Path | None = None,
) -> JobCell:
    """The real cell of a job (or of a run folder), as `twincell run` builds it for the seed:
    the same arm, errors and true placement; its controller moves the nominal arm."""
    config, run = _job(name, seed, overrides, cell)
    robot = job_robot(config.cell.robot)
    user = job_program(config, run) if run is not None else None
    virtual, real = object_models(config, user)
    return rebuild_job_cell(config, virtual, real, robot)


def serve_job(
    name: str,
    options: ServeOptions | None = None,
    *,
    seed: int | None = None,
    speed: float = 1.0,
    out: str | Path = "runs",
    spawn: bool = False,
    rrd: bool = False,
    progress: Progress | None = None,
    overrides: dict[str, object] | None = None,
    cell: str | Path | None = None,
) -> Serving:
    """Serve the real cell of job `name` (a shipped job, a CONFIG.yaml or a run folder) with
    `seed` (default the job's), in the `cell` (a shipped cell's name or a cell YAML; default
    the job's), the configuration's dotted keys set by `overrides`, its time `speed` times the
    wall clock's, served as `options` say (default: ServeOptions())."""
    say = progress or (lambda _m: None)
    options = options or ServeOptions()
    config, run = _job(name, seed, overrides, cell)
    robot = job_robot(config.cell.robot)
    if not robot.rapid:
        raise ScenarioError(f"{name}: the job's arm, the {robot.name}, does not run RAPID")
    user = job_program(config, run) if run is not None else None
    virtual, real = object_models(config, user)
    folder = serve_folder(out, config)
    recording = None
    if spawn or rrd:
        from scenarios.realcell.recording import Recording

        title = f"twincell serve {config.name} (seed {config.seed})"
        recording = Recording(
            folder / "serve.rrd", spawn=spawn, name=title, to_file=rrd, served=True
        )
        job = job_cell(config, virtual, real, robot, recording)
    else:
        job = rebuild_job_cell(config, virtual, real, robot)
    targets = job_targets(config, virtual, user)
    serving: Serving | None = None

    def touched(robtarget: str, tool: str | None) -> None:
        record_touch(job, targets, robtarget, tool)

    def ended(record: ExecutionRecord) -> None:
        if serving is not None:
            _measured(serving, record, targets, say)

    # the laser streams at the rate the job's scan reads it (its data sheet's); a point laser
    # reads on the controller's analog input, into the EGM stream, with no stream of its own
    analog = config.cell.laser.kind == "point"
    laser = replace(options.laser, period_s=config.localization.scan.period_s, analog=analog)
    options = replace(options, laser=laser, profiles_port=None if analog else options.profiles_port)
    twin = TwinController(job.controller, folder, speed, touched, ended, say, options.opmode)
    twin.elog.listeners.append(lambda e: _log(job, e))
    _helper_module(twin, say)
    if run is not None:
        _program_files(run, twin, say)
    served = ServedController(twin, options)
    serving = Serving(served, job, folder, config, recording=recording)
    say(f"the real cell of {config.name} (seed {config.seed}) serves RWS at {served.url}")
    if served.egm is not None:
        say(f"EGM to {served.egm.client[0]}:{served.egm.client[1]} every 4 ms")
    if served.profiles is not None:
        say(f"the line laser's profiles on TCP port {served.profiles.port}")
    if analog:
        say("the point laser on the analog input aiLaserRange, streamed with EGM by TcHelper")
    return serving


def _log(cell: JobCell, entry: ElogEntry) -> None:
    cell.log.say(f"event log {entry.code}: {entry.title}: {entry.desc}")


def _helper_module(twin: TwinController, say: Progress) -> None:
    """The cell as commissioned: twincell's helper module in $HOME and loaded into T_ROB1,
    as its user loads it on a real controller."""
    data = helper_text().encode("utf-8")
    path = f"$HOME/{HELPER_FILE.name}"
    twin.files.write(path, data)
    twin.task.load(data, path, replace=False)
    say(f"{path}: twincell's helper module, loaded into T_ROB1")


def _program_files(run: Path, twin: TwinController, say: Progress) -> None:
    """A run's program in the controller's $HOME, ready to load."""
    home = twin.files.resolve("$HOME")
    module, task = run / "program.mod", run / TASK_FOLDER
    if module.is_file():
        shutil.copy(module, home / module.name)
        say(f"$HOME/{module.name}: the run's program")
    if task.is_dir():
        shutil.copytree(task, home / TASK_FOLDER, dirs_exist_ok=True)
        say(f"$HOME/{TASK_FOLDER}/: the run's task")


def _measured(
    serving: Serving, record: ExecutionRecord, targets: JobTargets, say: Progress
) -> None:
    """Measure a program that ran to its end and write it to the serve folder."""
    result = measure_execution(serving.cell, record, targets)
    with serving.changed:
        serving.executions.append(result)
        number = len(serving.executions)
        serving.changed.notify_all()
    data = unstructure(result) | {"job": serving.config.name, "seed": serving.config.seed}
    text = json.dumps(data, indent=2) + "\n"
    name = f"{number:03d}-{Path(result.program).stem}.json"
    # in the serve folder, and in the controller's $HOME/executions (a client's to read: on
    # a real controller there is no such folder, for nothing there knows the truth)
    for folder in (serving.folder, serving.twin.files.resolve("$HOME")):
        (folder / EXECUTIONS).mkdir(exist_ok=True)
        write_text(folder / EXECUTIONS / name, text)
    path = serving.folder / EXECUTIONS / name
    rms = "-" if result.rms_m is None else f"{result.rms_m * 1e3:.3f} mm"
    say(f"{result.program}: {len(result.targets)} targets touched, rms {rms}; wrote {path}")
