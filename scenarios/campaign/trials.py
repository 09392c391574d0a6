"""Trials: one seeded, independent run of a trial function at one sweep point.

Trial ids are `p<point>-t<trial>`; the seed of trial k is `seed + k` at every sweep point
(common random numbers: sweep points are compared on the same draws).

A trial ends in one of three statuses: "ok" (the trial function returned its row, whatever
the run's verdict: a refused match or an aborted job is a result), "error" (it raised one of
the project's user errors, scenarios.scenario_errors.is_user_error: a bad configuration, input the
trial cannot use) or "crash" (it raised anything else: a bug). A crash's row carries its full
traceback under TRACEBACK_TEXT, which the campaign's store writes to the trial's folder.
"""

from __future__ import annotations

import importlib
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from scenarios.campaign.campaign_errors import CampaignError
from scenarios.results.edge import JsonObject
from scenarios.results.json_converter import unstructure
from scenarios.scenario_errors import is_user_error

STATUSES: tuple[str, ...] = ("ok", "error", "crash")
"""A trial row's `status`: returned, stopped by a user error, stopped by a program error."""

TRACEBACK_TEXT = "traceback_text"
"""The key of a crashed trial's full traceback in the row run_trial returns; the store
replaces it by the file it writes (scenarios.campaign.store.ResultStore.write)."""


TrialFunction = Callable[[JsonObject, int], object]
"""(resolved config dict, seed) -> the trial's typed row (e.g.
scenarios.campaign.register_row.RegisterRow), which the results' converter flattens to the
results table's columns, in the table's order (scenarios.results.json_converter.unstructure:
a dataclass's fields, or the columns its module registers)."""

STAGES: dict[str, str] = {
    "register": "scenarios.campaign.register_trial:run_register_trial",
    "full": "scenarios.campaign.full_stage:run_full_trial",
    "shift": "scenarios.campaign.shift_stage:run_shift_trial",
}
"""Trial function of each stage, as `module:function` (imported where the trial runs)."""


@dataclass(frozen=True)
class Trial:
    """One trial: its id, sweep point index and values, trial index, seed, stage and the
    fully resolved configuration it runs with."""

    trial_id: str
    point: int
    index: int
    seed: int
    stage: str
    config: JsonObject = field(hash=False)
    values: JsonObject = field(hash=False)


def trial_id(point: int, index: int) -> str:
    """The id of trial `index` at sweep point `point`."""
    return f"p{point:03d}-t{index:05d}"


def stage_function(stage: str) -> TrialFunction:
    """The trial function of `stage` (see STAGES)."""
    if stage not in STAGES:
        raise CampaignError(f"unknown stage {stage!r}; valid: {', '.join(STAGES)}")
    module, _, name = STAGES[stage].partition(":")
    return getattr(importlib.import_module(module), name)


def run_trial(trial: Trial) -> JsonObject:
    """Run one trial and return its row: ids, sweep values, status (STATUSES; "error" or
    "crash" with the exception and where it was raised in `error`, a crash with its full
    traceback under TRACEBACK_TEXT), and the trial function's metrics. Never raises for a
    failing trial: a failure is a result, recorded once like the others."""
    row: JsonObject = {
        "trial_id": trial.trial_id,
        "point": trial.point,
        "trial": trial.index,
        "seed": trial.seed,
        "stage": trial.stage,
        **{f"vary.{k}": "none" if v is None else v for k, v in trial.values.items()},
    }
    t0 = time.perf_counter()
    try:
        columns = unstructure(stage_function(trial.stage)(trial.config, trial.seed))
    except Exception as exc:
        return {**row, **_failure(exc), "trial_seconds": time.perf_counter() - t0}
    return {**row, "status": "ok", "error": "", **columns}


def _failure(exc: Exception) -> JsonObject:
    """The status columns of a trial stopped by `exc`: "error" for a user error (one line),
    "crash" for any other exception (one line, and the full traceback)."""
    last = traceback.extract_tb(exc.__traceback__)[-1]
    where = f"{last.filename.rsplit('/', 1)[-1]}:{last.lineno}"
    line = f"{type(exc).__name__}: {exc} ({where})"
    if is_user_error(exc):
        return {"status": "error", "error": line}
    text = "".join(traceback.format_exception(exc))
    return {"status": "crash", "error": line, TRACEBACK_TEXT: text}
