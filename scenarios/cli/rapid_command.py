"""`twincell rapid PATH...`: a RAPID task read as a controller would, and what was read."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from scenarios.cli.help_format import argument

EXAMPLES = (
    "twincell rapid examples/my_cell/burr_holes.mod",
    "twincell rapid tests/data/rapid/abb_driver_t_rob1",
)


def rapid(
    paths: Annotated[
        list[Path],
        argument(
            "PATH...",
            "A RAPID module file, several files of one task, or a folder (a backup's "
            "RAPID/TASKn with PROGMOD and SYSMOD, or any folder of .mod/.modx/.sys/.prg).",
            exists=True,
        ),
    ],
) -> None:
    """Read a RAPID task as a controller would; print what was read.

    Modules, routines, tools, work objects, robtargets, moves per routine, the motion
    instructions the executor refuses, and warnings (procedures called but defined nowhere).
    Exit status 2 with one line naming the file and the line when the task cannot be read.
    """
    from scenarios.rapid.summary import task_lines
    from scenarios.rapid.task import read_task

    for line in task_lines(read_task([str(path) for path in paths])):
        typer.echo(line)
