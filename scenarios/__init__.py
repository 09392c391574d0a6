"""Runnable jobs: paper, skull, assembly; offline programming, evaluation, logging, CLI.

    >>> from scenarios import run_job, RunOptions
    >>> folder, results = run_job("skull", seed=3, options=RunOptions(rrd=False))

The names below are imported on first use (PEP 562), so that the command line starts fast.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ScenarioError": "scenarios.errors",
    "ConfigError": "scenarios.config",
    "SkullConfig": "scenarios.config",
    "AssemblyConfig": "scenarios.config",
    "PaperConfig": "scenarios.config",
    "load_config": "scenarios.config",
    "parse_config": "scenarios.config",
    "RunOptions": "scenarios.runner",
    "run_job": "scenarios.runner",
    "run_skull": "scenarios.skull",
    "run_assembly": "scenarios.assembly",
    "Evaluator": "scenarios.evaluation",
    "OfflineProgram": "scenarios.program",
    "Operation": "scenarios.program",
    "plan_program": "scenarios.program",
    "execute_program": "scenarios.program",
    "plan_scan": "scenarios.scan",
    "execute_scan": "scenarios.scan",
    "probe_part": "scenarios.probing",
    "program_module": "scenarios.rapid",
    "Recording": "scenarios.recording",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'scenarios' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
