"""`twincell run NAME|CONFIG.yaml`: the registry of runnable jobs and the run-folder protocol.

A job is a function (config, run folder, progress, options) -> results. The runner creates
the folder, writes the resolved config.yaml first and results.json last; if the job fails or
is interrupted, results.json says "status": "incomplete" with the reason, and the error goes
on. A job may report its own status (the skull job says "refused" when the match is not
accepted).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from scenarios.errors import ScenarioError
from scenarios.jobs.config import (
    AssemblyConfig,
    Config,
    PaperConfig,
    SkullConfig,
    config_yaml,
    load_config,
)
from scenarios.outputs.run_folder import RunFolder

Progress = Callable[[str], None]


@dataclass(frozen=True)
class RunOptions:
    """Options of one run that are not part of the scenario: the rerun recording to a file
    (`rrd`), a live viewer (`spawn`)."""

    rrd: bool = True
    spawn: bool = False


Job = Callable[[Any, RunFolder, Progress, RunOptions], dict[str, Any]]


def _paper(
    config: PaperConfig, folder: RunFolder, progress: Progress, options: RunOptions
) -> dict[str, Any]:
    from scenarios.jobs.paper import TESTS, plot_cases, run_paper, table_text

    cases = run_paper(config.seed, progress)
    rows = [case.row for case in cases]
    folder.write_text("paper_table.txt", table_text(rows))
    plot_cases(cases, str(folder.file("paper.png")))
    return {
        "tests": [asdict(t) for t in TESTS],
        "rows": [asdict(r) for r in rows],
        "table": table_text(rows),
    }


def _recording(folder: RunFolder, config: Any, options: RunOptions) -> Any:
    if not (options.rrd and config.output.rrd) and not options.spawn:
        return None
    from scenarios.outputs.recording import Recording

    return Recording(folder.file("run.rrd"), spawn=options.spawn)


def _recorded(
    run: Any, config: Any, folder: RunFolder, progress: Progress, options: RunOptions
) -> dict[str, Any]:
    """Run a scenario with its recording; the recording is kept only if the run completes."""
    recording = _recording(folder, config, options)
    try:
        results = run(config, folder.path, progress, recording)
    except BaseException:
        if recording is not None:
            recording.close(keep=False)
        raise
    if recording is not None:
        recording.close(keep=True)
    return results


def _skull(
    config: SkullConfig, folder: RunFolder, progress: Progress, options: RunOptions
) -> dict[str, Any]:
    from scenarios.jobs.skull import run_skull

    return _recorded(run_skull, config, folder, progress, options)


def _assembly(
    config: AssemblyConfig, folder: RunFolder, progress: Progress, options: RunOptions
) -> dict[str, Any]:
    from scenarios.jobs.assembly import run_assembly

    return _recorded(run_assembly, config, folder, progress, options)


JOBS: dict[str, Job] = {"paper": _paper, "skull": _skull, "assembly": _assembly}


def run_job(
    name: str | Path | Config,
    seed: int | None = None,
    out: str | Path = "runs",
    progress: Progress | None = None,
    overrides: dict[str, Any] | None = None,
    options: RunOptions | None = None,
) -> tuple[Path, dict[str, Any]]:
    """Run a shipped job by name, a YAML config by path, or a config object, into a new run
    folder; returns the folder and the results. `seed` and `overrides` (top-level keys such
    as model, units) replace the file's values."""
    extra = dict(overrides or {})
    if seed is not None:
        extra["seed"] = seed
    if isinstance(name, SkullConfig | AssemblyConfig | PaperConfig):
        config: Config = type(name).model_validate({**name.model_dump(), **extra})
    else:
        config = load_config(name, extra)
    if config.scenario not in JOBS:
        raise ScenarioError(
            f"unknown scenario {config.scenario!r}; available: {', '.join(sorted(JOBS))}"
        )
    say = progress or (lambda _msg: None)
    label = config.scenario if not isinstance(name, str | Path) else Path(str(name)).stem
    folder = RunFolder(out, label)
    folder.write_text("config.yaml", config_yaml(config))
    results: dict[str, Any] = {
        "status": "incomplete",
        "reason": "running",
        "scenario": config.scenario,
        "seed": config.seed,
    }
    folder.write_json("results.json", results)
    t0 = time.perf_counter()
    try:
        results.update(JOBS[config.scenario](config, folder, say, options or RunOptions()))
    except BaseException as exc:
        reason = "interrupted" if isinstance(exc, KeyboardInterrupt) else f"{exc}"
        results.update(status="incomplete", reason=reason)
        folder.write_json("results.json", results)
        folder.link_latest()
        raise
    if results.get("status") == "incomplete":
        results.update(status="complete", reason="")
    results["seconds"] = time.perf_counter() - t0
    folder.write_json("results.json", results)
    folder.link_latest()
    return folder.path, results
