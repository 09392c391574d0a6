"""A campaign: N seeded trials per sweep point, run on a backend, stored, aggregated.

    >>> spec = plan_campaign(
    ...     "skull", stage="register", trials=200, vary=["register_trial.case=default,outliers"]
    ... )
    >>> outcome = run_campaign(spec, out="runs/campaigns/skull-register", workers=2)

The campaign folder holds `campaign.yaml` (the resolved campaign: stage, base configuration,
sweep, trials, seed), `trials/*.json` (one row per finished trial; a crashed trial's
traceback in `trials/<trial_id>/traceback.txt`), `results.csv`, and the report
(`report.md`, `report.json`, PNG figures). Running the same campaign into the same
folder resumes it; a different campaign there is refused.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import yaml

from models.atomic import write_text
from scenarios.campaign.campaign_errors import CampaignError
from scenarios.campaign.register_job import (
    CASE_KEY,
    CASES,
    MODELS,
    check_read_keys,
    parse_register_job,
    register_base,
)
from scenarios.campaign.store import ResultStore
from scenarios.campaign.sweep import Sweep, parse_vary, set_dotted, sweep_points
from scenarios.campaign.trials import STAGES, Trial, trial_id
from scenarios.configuration.config_files import read_yaml_mapping
from scenarios.results.edge import JsonObject

Backend = Literal["local", "dask"]
BACKENDS: tuple[str, ...] = ("local", "dask")
#: The stages whose trials run a cell job (a job configuration, in a cell one may give).
CELL_STAGES: tuple[str, ...] = ("full", "shift")


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign runs: `trials` seeds (`seed`, `seed + 1`, ...) at every point of
    `sweep`, on the `stage`'s trial function with `base_config` (a plain dict, every key)."""

    name: str
    stage: str
    base_config: JsonObject
    sweep: Sweep
    trials: int
    seed: int = 0

    def identity(self) -> JsonObject:
        """What must match for a folder to be resumed (the trial count may grow)."""
        return {
            "name": self.name,
            "stage": self.stage,
            "seed": self.seed,
            "base_config": self.base_config,
            "sweep": [[k, list(v)] for k, v in self.sweep],
        }


def base_config(name: str, stage: str, cell: str | None = None) -> JsonObject:
    """The base configuration of a campaign, a job configuration (JobConfig) as a plain dict
    (every key): for the register stage the default job on a built-in model (skull,
    ellipsoid, bracket, housing, lid) or a job YAML file (its `register_trial` section the
    defaults where it has none; scenarios.campaign.register_job); for the full and the
    shift stage a shipped job (skull, assembly) or a job YAML file, run headless, in `cell`
    (a shipped cell by name or a cell YAML, as `twincell run --cell` takes it) if one is
    given."""
    if cell is not None and stage not in CELL_STAGES:
        raise CampaignError(
            f"a cell ({cell!r}) is for the {' and '.join(CELL_STAGES)} stages; the {stage} "
            "stage runs no cell"
        )
    if stage == "register":
        if name in MODELS:
            return register_base(name)
        path = Path(name)
        if path.suffix not in (".yaml", ".yml"):
            raise CampaignError(
                f"unknown campaign {name!r} for the register stage; give a model "
                f"({', '.join(MODELS)}) or a .yaml file"
            )
        data = read_yaml_mapping(path, CampaignError)
        data.setdefault("name", path.stem)
        return parse_register_job(data, str(path)).job.model_dump(mode="json")
    if stage in CELL_STAGES:
        from scenarios.configuration.config_files import load_config

        config = load_config(name, cell=cell).model_dump(mode="json")
        if "output" in config:
            config["output"] = {**config["output"], "rrd": False, "plots": False}
        return config
    raise CampaignError(f"unknown stage {stage!r}; valid: {', '.join(STAGES)}")


def plan_campaign(
    name: str,
    stage: str = "register",
    trials: int = 10,
    vary: list[str] | tuple[str, ...] = (),
    seed: int = 0,
    cell: str | None = None,
) -> CampaignSpec:
    """A campaign of `trials` per point of the `vary` sweep (`KEY=V1,V2,...`, the job's
    dotted keys); every point's configuration is resolved and validated now, so that a bad
    key fails before any trial (for the register stage, a key its trial does not read
    too)."""
    if stage not in STAGES:
        raise CampaignError(f"unknown stage {stage!r}; valid: {', '.join(STAGES)}")
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise CampaignError(f"trials must be a positive integer, got {trials!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CampaignError(f"seed must be a non-negative integer, got {seed!r}")
    sweep = parse_vary(vary)
    label = Path(name).stem if cell is None else f"{Path(name).stem}-{Path(cell).stem}"
    spec = CampaignSpec(label, stage, base_config(name, stage, cell), sweep, trials, seed)
    for values in sweep_points(spec.sweep):
        resolve_config(spec, values)
    if stage == "register":
        check_read_keys(k for k, _ in sweep)
    return spec


def resolve_config(spec: CampaignSpec, values: JsonObject) -> JsonObject:
    """The configuration of one sweep point: the base, then a register case's preset keys
    (CASES, when `register_trial.case` is swept), then the other swept keys; validated."""
    config = spec.base_config
    register = spec.stage == "register"
    if register and CASE_KEY in values:
        case = values[CASE_KEY]
        if case not in CASES:
            raise CampaignError(f"unknown case {case!r}; valid: {', '.join(CASES)}")
        config = set_dotted(config, CASE_KEY, case)
        for key, value in CASES[case].items():
            config = set_dotted(config, key, value)
    for key, value in values.items():
        if not (register and key == CASE_KEY):
            config = set_dotted(config, key, value)
    label = ", ".join(f"{k}={v}" for k, v in values.items()) or "base"
    if register:
        return parse_register_job(config, f"sweep point {label}").job.model_dump(mode="json")
    from scenarios.configuration.config_error import ConfigError
    from scenarios.configuration.config_files import parse_config

    try:
        return parse_config(config, f"sweep point {label}").model_dump(mode="json")
    except ConfigError as exc:
        raise CampaignError(str(exc)) from None


def campaign_trials(spec: CampaignSpec) -> list[Trial]:
    """Every trial of the campaign, point by point."""
    trials = []
    for point, values in enumerate(sweep_points(spec.sweep)):
        config = resolve_config(spec, values)
        for k in range(spec.trials):
            trials.append(
                Trial(trial_id(point, k), point, k, spec.seed + k, spec.stage, config, values)
            )
    return trials


def _check_folder(spec: CampaignSpec, folder: Path) -> None:
    """Refuse a folder that holds another campaign; write the resolved campaign otherwise."""
    path = folder / "campaign.yaml"
    record = {
        **spec.identity(),
        "trials": spec.trials,
        "points": [
            {"point": i, "values": v, "config": resolve_config(spec, v)}
            for i, v in enumerate(sweep_points(spec.sweep))
        ],
    }
    if path.is_file():
        old = yaml.safe_load(path.read_text()) or {}
        mismatched = [
            k for k, v in spec.identity().items() if old.get(k) != yaml.safe_load(yaml.safe_dump(v))
        ]
        if mismatched:
            raise CampaignError(
                f"{folder} holds another campaign (different {', '.join(mismatched)}); "
                f"resume it with the same options or choose another --out"
            )
        record["trials"] = max(spec.trials, int(old.get("trials", 0)))
    write_text(path, yaml.safe_dump(record, sort_keys=False))


@dataclass(frozen=True)
class CampaignOutcome:
    """A finished campaign: its folder, the rows of the requested trials, how many ran now
    (the others were finished before), and the report's files."""

    folder: Path
    rows: list[JsonObject]
    ran: int
    skipped: int
    files: tuple[Path, ...]

    @property
    def crashed(self) -> list[JsonObject]:
        """The rows of the trials stopped by a program error (status "crash"), each naming
        its traceback's file (relative to the folder) in `traceback`."""
        return [r for r in self.rows if r["status"] == "crash"]


def run_campaign(
    spec: CampaignSpec,
    out: str | Path,
    backend: str = "local",
    workers: int = 1,
    scheduler: str | None = None,
    progress: bool = True,
    on_row: Callable[[JsonObject], None] | None = None,
) -> CampaignOutcome:
    """Run the unfinished trials of `spec` into the folder `out` on `backend` ("local": K
    processes; "dask": the scheduler at `scheduler`, or a local cluster of `workers`), then
    write results.csv and the report."""
    if backend not in BACKENDS:
        raise CampaignError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise CampaignError(f"workers must be a positive integer, got {workers!r}")
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    _check_folder(spec, folder)
    store = ResultStore(folder)
    trials = campaign_trials(spec)
    done = store.done()
    todo = [t for t in trials if t.trial_id not in done]
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")  # one core per worker process

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    bar = Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        disable=not progress,
        transient=False,
    )
    with bar:
        task = bar.add_task(
            f"{spec.name} ({spec.stage})", total=len(trials), completed=len(trials) - len(todo)
        )

        def collect(row: JsonObject) -> None:
            store.write(row)
            bar.advance(task)
            if on_row is not None:
                on_row(row)

        if todo:
            if backend == "local":
                from scenarios.campaign.local import run_local

                run_local(todo, workers, collect)
            else:
                from scenarios.campaign.cluster import run_dask

                run_dask(todo, collect, scheduler, workers)
    rows = store.rows(t.trial_id for t in trials)
    csv_path = store.write_csv(folder / "results.csv", rows)
    from scenarios.campaign.campaign_report import write_report

    files = (csv_path, *write_report(folder, csv_path, spec.stage, [k for k, _ in spec.sweep]))
    return CampaignOutcome(folder, rows, len(todo), len(trials) - len(todo), files)


def default_out(spec: CampaignSpec) -> Path:
    """The default campaign folder: runs/campaigns/<name>-<stage>[-<swept keys>]."""
    keys = "-".join(k for k, _ in spec.sweep)
    return Path("runs") / "campaigns" / "-".join(p for p in (spec.name, spec.stage, keys) if p)
