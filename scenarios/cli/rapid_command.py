"""`twincell rapid PATHS...`: a RAPID task read as a controller would, and what was read."""

from __future__ import annotations

from typing import Annotated

import typer


def rapid(
    paths: Annotated[
        list[str],
        typer.Argument(
            help="A RAPID module file, several files of one task, or a folder (a backup's "
            "RAPID/TASKn with PROGMOD and SYSMOD, or any folder of .mod/.modx/.sys/.prg)."
        ),
    ],
) -> None:
    """Read a RAPID task as a controller would and print what was read: modules, routines,
    tools, work objects, robtargets, moves per routine, the motion instructions the executor
    refuses, and warnings (procedures called but defined nowhere). Exit 2 with one line
    naming the file and the line when the task cannot be read."""
    from scenarios.rapid.summary import task_lines
    from scenarios.rapid.task import read_task

    for line in task_lines(read_task(paths)):
        typer.echo(line)
