"""`twincell campaign`: many seeded trials (a sweep), one row per trial, and the reliability
report."""

from __future__ import annotations

from typing import Annotated

import typer

from scenarios.cli.help_format import argument, flag, option

# The help's panels of `twincell campaign`.
TRIALS = "Trials"
WORKERS = "Workers"
OUTPUT = "Output"

EXAMPLES = (
    "twincell campaign skull --trials 20 --vary cell.noise.laser_sigma_m=1e-4,3e-4",
    "twincell campaign skull --stage full --trials 20 --workers 2",
    "twincell campaign skull --stage shift --trials 20 --vary shift.policy=check,once,every",
)


NameArgument = Annotated[
    str,
    argument(
        "NAME",
        "register stage: a model (skull, ellipsoid, ...) or a job CONFIG.yaml (with its "
        "register_trial section); full and shift stages: a shipped job (skull, assembly) or "
        "a CONFIG.yaml.",
    ),
]
StageOption = Annotated[
    str,
    option(
        "--stage",
        "[register|full|shift]",
        "register (matching alone), full (the scenario) or shift (one cell through a shift "
        "of jobs, the job's shift section).",
        TRIALS,
    ),
]
TrialsOption = Annotated[
    int, option("--trials", "INTEGER", "Seeded trials per point.", TRIALS, min=1)
]
SeedOption = Annotated[int, option("--seed", "INTEGER", "Seed of the first trial.", TRIALS, min=0)]
VaryOption = Annotated[
    list[str] | None,
    option(
        "--vary",
        "KEY=V1,V2,...",
        "The values of a dotted configuration key, one point each; repeat to cross.",
        TRIALS,
    ),
]
CellOption = Annotated[
    str | None,
    option(
        "--cell",
        "CELL",
        "full and shift stages: the cell to run each trial in, as `twincell run --cell` takes it "
        "(ur5, or a cell YAML).",
        TRIALS,
    ),
]
WorkersOption = Annotated[int, option("--workers", "INTEGER", "Worker processes.", WORKERS, min=1)]
BackendOption = Annotated[
    str,
    option("--backend", "[local|dask]", "local (processes here) or dask (a cluster).", WORKERS),
]
SchedulerOption = Annotated[
    str | None,
    option(
        "--scheduler",
        "ADDRESS",
        "Dask scheduler address (tcp://HOST:8786); none: a local Dask cluster of --workers "
        "processes.",
        WORKERS,
    ),
]
OutOption = Annotated[
    str | None,
    option(
        "--out",
        "DIR",
        "Campaign folder (default runs/campaigns/NAME-STAGE-KEYS); rerunning into it resumes.",
        OUTPUT,
    ),
]
QuietOption = Annotated[bool, flag("--quiet", "No progress bar.", OUTPUT)]


def campaign(
    name: NameArgument,
    stage: StageOption = "register",
    trials: TrialsOption = 10,
    seed: SeedOption = 0,
    vary: VaryOption = None,
    cell: CellOption = None,
    workers: WorkersOption = 1,
    backend: BackendOption = "local",
    scheduler: SchedulerOption = None,
    out: OutOption = None,
    quiet: QuietOption = False,
) -> None:
    """Run many seeded trials (a sweep) and report their reliability.

    Each trial is one row of the campaign's table (results.csv); the report (report.md) gives
    per point of the sweep the verdicts, the acceptance, the false accepts, the target errors
    and the calibration of the predicted TRE. A trial stopped by a user error (a configuration
    it cannot use) is a failed row; one stopped by a program error (a bug) is a crashed row,
    its traceback in the campaign folder's trials/ID/traceback.txt, and the command exits 5
    once the table and the report are written.
    """
    from scenarios.campaign import default_out, plan_campaign, run_campaign

    spec = plan_campaign(name, stage=stage, trials=trials, vary=vary or [], seed=seed, cell=cell)
    folder = out if out is not None else default_out(spec)
    outcome = run_campaign(
        spec, folder, backend=backend, workers=workers, scheduler=scheduler, progress=not quiet
    )
    typer.echo((outcome.folder / "report.md").read_text())
    typer.echo(
        f"campaign folder: {outcome.folder} ({outcome.ran} trials run now, "
        f"{outcome.skipped} finished before)"
    )
    if outcome.crashed:
        typer.echo(
            f"twincell: internal error: {len(outcome.crashed)} of {len(outcome.rows)} trials "
            f"crashed (a program error, not a refusal); tracebacks in "
            f"{outcome.folder / 'trials'}/<trial_id>/traceback.txt",
            err=True,
        )
        raise typer.Exit(5)
