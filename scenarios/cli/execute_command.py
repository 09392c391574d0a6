"""`twincell execute RUN_FOLDER`: a run's RAPID program run on its real cell and measured."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from scenarios.cli.help_format import argument, flag, option
from scenarios.cli.progress_lines import progress_lines

EXAMPLES = ("twincell execute runs/latest",)


def execute(
    run_folder: Annotated[
        Path,
        argument(
            "RUN_FOLDER",
            "A run folder written by `twincell run` (config.yaml inside).",
            exists=True,
            file_okay=False,
        ),
    ],
    program: Annotated[
        Path | None,
        option(
            "--program",
            "PATH",
            "The RAPID module (.mod), or a folder of a task's modules, to run instead of the "
            "folder's program.",
            exists=True,
        ),
    ] = None,
    quiet: Annotated[bool, flag("--quiet", "No progress lines.")] = False,
) -> None:
    """Run a run's RAPID program on its real cell; measure the targets.

    The real cell runs the program as an IRC5 without absolute accuracy (the arm's nominal
    kinematics); the touched targets are measured against the truth, and execution.json is
    written into the run folder.
    """
    from rich.console import Console

    from scenarios.jobs.execute_run_folder import EXECUTION_FILE, execute_run, execution_table

    folder = str(run_folder)  # the folder's name as the messages give it
    result = execute_run(folder, None if program is None else str(program), progress_lines(quiet))
    Console().print(execution_table(result))
    typer.echo(f"wrote {Path(folder) / EXECUTION_FILE}")
