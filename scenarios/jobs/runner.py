"""`twincell run NAME|CONFIG.yaml`: the run-folder protocol around a job.

A job is a configuration: a cell job (scenarios.jobs.pipeline) or the seed paper's
experiments. The runner creates the folder, writes the resolved config.yaml first and
results.json last, in one place; if the job fails or is interrupted, results.json says
"status": "incomplete" with the reason and the `stage` the run was in (a StageTracker that
the job moves on), and the error goes on. A cell job reports its own status ("refused" when
the localization is not accepted).

SIGINT and SIGTERM stop a run in any stage (in the main thread): the signal raises
RunInterrupted where the run is, the stack unwinds (nothing more is commanded to the cell,
the recording is discarded), results.json says "reason": "interrupted (SIGTERM)" and the
stage, and no file is left half-written: each is complete or absent.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from scenarios.configuration.config_files import (
    cell_overrides,
    config_yaml,
    load_config,
    with_overrides,
)
from scenarios.configuration.job_config import Config, JobConfig, PaperConfig
from scenarios.jobs.interrupt import RunInterrupted, SignalGuard
from scenarios.jobs.network_job import ControllerAddress
from scenarios.jobs.paper import PaperResult
from scenarios.jobs.stage_tracker import StageTracker
from scenarios.outputs.run_folder import RunFolder
from scenarios.results.edge import JsonObject
from scenarios.results.json_converter import unstructure
from scenarios.results.run import IncompleteRun, RunResult
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]


@dataclass(frozen=True)
class RunOptions:
    """Options of one run that are not part of the scenario: the rerun recording to a file
    (`rrd`), a live viewer (`spawn`), the user's cache folder read and written (`cache`:
    False makes the skull phantom and the scan plan anew and stores nothing; see
    models.cache); the `controller` across the network the job runs on (None: its real cell,
    simulated in this process; across the network, the recording draws the cell as the job
    knows it, posed by the controller's stream); the cell's `commissioning` record from an
    earlier run (None: the job commissions the cell when it first needs to); the cell's
    `calibration` an earlier run saved (None: the job calibrates it)."""

    rrd: bool = True
    spawn: bool = False
    cache: bool = True
    controller: ControllerAddress | None = None
    commissioning: Path | None = None
    calibration: Path | None = None


JobResult = RunResult | PaperResult
Job = Callable[[Any, RunFolder, Progress, RunOptions, StageTracker], JobResult]


def _paper(
    config: PaperConfig,
    folder: RunFolder,
    progress: Progress,
    options: RunOptions,
    stages: StageTracker,
) -> PaperResult:
    from scenarios.jobs.paper import plot_cases, run_paper

    stages.enter("experiments")
    cases = run_paper(config.seed, progress)
    stages.enter("export")
    result = PaperResult(config.name, config.seed, tuple(case.row for case in cases))
    folder.write_text("paper_table.txt", result.table)
    plot_cases(cases, str(folder.file("paper.png")))
    return result


def _recording(folder: RunFolder, config: Any, options: RunOptions) -> Any:
    if not (options.rrd and config.output.rrd) and not options.spawn:
        return None
    from scenarios.realcell.recording import Recording

    name = f"{folder.path.name} (seed {config.seed})"
    to_file = options.rrd and config.output.rrd
    return Recording(folder.file("run.rrd"), spawn=options.spawn, name=name, to_file=to_file)


def _cell(
    config: JobConfig,
    folder: RunFolder,
    progress: Progress,
    options: RunOptions,
    stages: StageTracker,
) -> RunResult:
    """A cell job through the pipeline, with its recording: kept only if the run completes,
    discarded (no run.rrd, no partial file) if anything stops it, closing included."""
    from scenarios.jobs.pipeline import run_cell_job

    remote = options.controller
    recording = _recording(folder, config, options)
    try:
        result = run_cell_job(
            config, folder.path, progress, recording, stages=stages, use_cache=options.cache,
            address=remote, commissioning=options.commissioning,
            calibration=options.calibration,
        )  # fmt: skip
        if recording is not None:
            recording.close(keep=True)
    except BaseException:
        if recording is not None:
            recording.close(keep=False)
            folder.file("run.rrd").unlink(missing_ok=True)  # a stop after it was moved in place
        raise
    return result


JOBS: dict[str, Job] = {"paper": _paper, "cell": _cell}


def run_job(
    name: str | Path | Config,
    seed: int | None = None,
    out: str | Path = "runs",
    progress: Progress | None = None,
    overrides: JsonObject | None = None,
    options: RunOptions | None = None,
    cell: str | Path | None = None,
) -> tuple[Path, JobResult]:
    """Run a shipped job by name, a YAML config by path, or a config object, into a new run
    folder; returns the folder and the result (what results.json holds). `seed` and
    `overrides` (dotted keys, e.g. {"cell.object.model": "part.stl"}) replace the
    configuration's values, after those of the `cell` (a shipped cell's name, e.g. "ur5", or
    a cell YAML) if one is given."""
    with SignalGuard() as guard:  # from here on SIGINT and SIGTERM raise RunInterrupted
        return _run(_config(name, seed, overrides, cell), out, progress, options, guard)


def _config(
    name: str | Path | Config,
    seed: int | None,
    overrides: JsonObject | None,
    cell: str | Path | None,
) -> Config:
    """The job's configuration, with the cell's values, then the seed and overrides."""
    extra = dict(overrides or {})
    if seed is not None:
        extra["seed"] = seed
    if isinstance(name, JobConfig | PaperConfig):
        config: Config = name
        if cell is not None:
            config = with_overrides(config, cell_overrides(cell), f"cell {cell}")
        return with_overrides(config, extra) if extra else config
    return load_config(name, extra, cell)


def _run(
    config: Config,
    out: str | Path,
    progress: Progress | None,
    options: RunOptions | None,
    guard: SignalGuard,
) -> tuple[Path, JobResult]:
    """The run of `config` into a new folder under `out`; `guard` is told when the run
    winds down (an error, a signal) or is done, after which no signal interrupts it."""
    if config.kind not in JOBS:
        raise ScenarioError(f"unknown kind {config.kind!r}; available: {', '.join(sorted(JOBS))}")
    say = progress or (lambda _msg: None)
    stages = StageTracker()
    folder = RunFolder(out, config.name)
    try:
        folder.write_text("config.yaml", config_yaml(config))
        running = IncompleteRun(config.name, config.seed, "running")
        folder.write_json("results.json", unstructure(running))
        t0 = time.perf_counter()
        result = JOBS[config.kind](config, folder, say, options or RunOptions(), stages)
        guard.hold()  # the job is done: a signal from here on does not undo it
    except BaseException as exc:
        guard.hold()  # winding down: a second signal does not interrupt the clean-up
        stopped = IncompleteRun(config.name, config.seed, _reason(exc), stages.current)
        folder.write_json("results.json", unstructure(stopped))
        folder.link_latest()
        folder.remove_partial()
        if isinstance(exc, RunInterrupted):
            exc.stage, exc.folder = stages.current, str(folder.path)
        raise
    result = replace(result, seconds=time.perf_counter() - t0)
    folder.write_json("results.json", unstructure(result))
    folder.link_latest()
    return folder.path, result


def _reason(exc: BaseException) -> str:
    """results.json's reason of a run stopped by `exc`."""
    if isinstance(exc, RunInterrupted):
        return exc.reason
    if isinstance(exc, KeyboardInterrupt):  # Python's own SIGINT exception, raised elsewhere
        return "interrupted (SIGINT)"
    return f"{exc}"
