"""A run folder's results.json read back as the run's typed result (`read_results`); the
runner writes it with the results' converter (scenarios.results.json_converter)."""

from __future__ import annotations

import json
from pathlib import Path

from scenarios.results.json_converter import structure
from scenarios.results.run import ResultsError, RunResult


def read_results(path: str | Path) -> RunResult:
    """The result in a run folder's results.json (`path`: the file or its folder);
    ResultsError if there is none, or it is not a finished cell job's of this schema
    (RunNotEndedError for a run that did not end)."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.json"
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ResultsError(f"no results.json at {path}") from None
    except json.JSONDecodeError as exc:
        raise ResultsError(f"{path} is not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ResultsError(f"{path} holds a {type(data).__name__}, not a run's results")
    try:
        return structure(data, RunResult)
    except ResultsError as exc:
        raise type(exc)(f"{path}: {exc}") from None
