"""Runnable jobs (one pipeline for every cell job, and the seed paper's experiments), the
offline stages, the simulated real cell and its evaluation, the outputs, the command line.

    >>> from scenarios import run_job, RunOptions
    >>> folder, results = run_job("skull", seed=3, options=RunOptions(rrd=False))

The names below are imported on first use (PEP 562), so that the command line starts fast.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ScenarioError": "scenarios.errors",
    "ConfigError": "scenarios.jobs.config",
    "JobConfig": "scenarios.jobs.config",
    "PaperConfig": "scenarios.jobs.config",
    "load_config": "scenarios.jobs.config",
    "parse_config": "scenarios.jobs.config",
    "RunOptions": "scenarios.jobs.runner",
    "run_job": "scenarios.jobs.runner",
    "run_cell_job": "scenarios.jobs.pipeline",
    "RunResult": "scenarios.jobs.result",
    "Evaluator": "scenarios.realcell.evaluation",
    "OfflineProgram": "scenarios.offline.program",
    "Operation": "scenarios.offline.program",
    "plan_program": "scenarios.offline.program",
    "execute_program": "scenarios.offline.program",
    "plan_scan": "scenarios.offline.scan",
    "execute_scan": "scenarios.offline.scan",
    "probe_part": "scenarios.offline.probing",
    "program_module": "scenarios.offline.rapid",
    "Recording": "scenarios.outputs.recording",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'scenarios' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
