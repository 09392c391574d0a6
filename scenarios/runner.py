"""`twincell run NAME`: the registry of runnable jobs and the run-folder protocol.

A job is a function (seed, run folder, progress) -> summary rows. The runner creates the
folder, writes config.yaml first and results.json last; if the job fails or is interrupted,
results.json says "status": "incomplete" with the reason, and the error goes on.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import yaml

from scenarios.errors import ScenarioError
from scenarios.run_folder import RunFolder

Progress = Callable[[str], None]
Job = Callable[[int, RunFolder, Progress], dict[str, Any]]


def _paper(seed: int, folder: RunFolder, progress: Progress) -> dict[str, Any]:
    from scenarios.paper import TESTS, plot_cases, run_paper, table_text

    cases = run_paper(seed, progress)
    rows = [case.row for case in cases]
    folder.write_text("paper_table.txt", table_text(rows))
    plot_cases(cases, str(folder.file("paper.png")))
    return {
        "tests": [asdict(t) for t in TESTS],
        "rows": [asdict(r) for r in rows],
        "table": table_text(rows),
    }


JOBS: dict[str, Job] = {"paper": _paper}


def run_job(
    name: str, seed: int = 0, out: str | Path = "runs", progress: Progress | None = None
) -> tuple[Path, dict[str, Any]]:
    """Run a job by name into a new run folder; returns the folder and the results."""
    if name not in JOBS:
        raise ScenarioError(f"unknown scenario {name!r}; available: {', '.join(sorted(JOBS))}")
    say = progress or (lambda _msg: None)
    folder = RunFolder(out, name)
    config = {"scenario": name, "seed": seed}
    folder.write_text("config.yaml", yaml.safe_dump(config, sort_keys=False))
    results: dict[str, Any] = {"status": "incomplete", "reason": "running", **config}
    folder.write_json("results.json", results)
    t0 = time.perf_counter()
    try:
        results.update(JOBS[name](seed, folder, say))
    except BaseException as exc:
        reason = "interrupted" if isinstance(exc, KeyboardInterrupt) else f"{exc}"
        results.update(status="incomplete", reason=reason)
        folder.write_json("results.json", results)
        folder.link_latest()
        raise
    results.update(status="complete", reason="", seconds=time.perf_counter() - t0)
    folder.write_json("results.json", results)
    folder.link_latest()
    return folder.path, results
