"""`twincell campaign`: many seeded trials (a sweep), one row per trial, and the reliability
report."""

from __future__ import annotations

from typing import Annotated

import typer


def campaign(
    name: Annotated[
        str,
        typer.Argument(
            help="register stage: a model (skull, ellipsoid, ...) or a job CONFIG.yaml "
            "(with its register_trial section); full stage: a shipped job (skull, assembly) "
            "or a CONFIG.yaml."
        ),
    ],
    trials: Annotated[int, typer.Option("--trials", min=1, help="Seeded trials per point.")] = 10,
    vary: Annotated[
        list[str] | None,
        typer.Option("--vary", help="KEY=V1,V2,... (dotted config key); repeat to cross."),
    ] = None,
    workers: Annotated[int, typer.Option("--workers", min=1, help="Worker processes.")] = 1,
    backend: Annotated[
        str, typer.Option("--backend", help="local (processes here) or dask (a cluster).")
    ] = "local",
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address (tcp://HOST:8786); none: "
            "a local Dask cluster of --workers processes.",
        ),
    ] = None,
    stage: Annotated[
        str, typer.Option("--stage", help="register (matching alone) or full (the scenario).")
    ] = "register",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the first trial.")] = 0,
    cell: Annotated[
        str | None,
        typer.Option(
            "--cell",
            help="full stage: the cell to run each trial in, as `twincell run --cell` "
            "takes it (ur5, or a cell YAML).",
        ),
    ] = None,
    out: Annotated[
        str | None,
        typer.Option(
            "--out",
            help="Campaign folder (default runs/campaigns/NAME-STAGE-KEYS); "
            "rerunning into it resumes.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Run many seeded trials (a sweep), store one row per trial, report reliability.

    A trial stopped by a user error (a configuration it cannot use) is a failed row; one
    stopped by a program error (a bug) is a crashed row, its traceback in the campaign
    folder's trials/ID/traceback.txt, and the command exits 5 once the table and the report
    are written.
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
