"""`twincell check`: the cell's self-check."""

from __future__ import annotations

from typing import Annotated

import typer

from scenarios.cli.help_format import option

EXAMPLES = ("twincell check --json check.json",)


def check(
    json_file: Annotated[
        str | None, option("--json", "FILE", "Also write the figures to this JSON file.")
    ] = None,
) -> None:
    """Self-check of the cell: physics, FK/IK, tools, table, laser.

    Checks the physics, the forward and inverse kinematics, the tool changes, the table and the
    laser. Exit status 0 if all hold, 1 if one does not.
    """
    from rich.console import Console

    from cell.sim.selfcheck import render, run_check, write_json

    report = run_check()
    Console().print(render(report))
    if json_file is not None:
        write_json(report, json_file)
    if not report.passed:
        raise typer.Exit(1)
