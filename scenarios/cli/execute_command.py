"""`twincell execute RUN_FOLDER`: a run's RAPID program run on its real cell and measured."""

from __future__ import annotations

from typing import Annotated

import typer


def execute(
    run_folder: Annotated[
        str, typer.Argument(help="A run folder written by `twincell run` (config.yaml inside).")
    ],
    program: Annotated[
        str | None,
        typer.Option(
            "--program",
            help="The RAPID module (.mod), or a folder of a task's modules, to run instead "
            "of the folder's program.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Run a run's RAPID program on its real cell as an IRC5 without absolute accuracy (the
    arm's nominal kinematics) and measure the touched targets against the truth; writes
    execution.json into the run folder."""
    from pathlib import Path

    from rich.console import Console

    from scenarios.jobs.execute_run_folder import EXECUTION_FILE, execute_run, execution_table

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    result = execute_run(run_folder, program, progress)
    Console().print(execution_table(result))
    typer.echo(f"wrote {Path(run_folder) / EXECUTION_FILE}")
