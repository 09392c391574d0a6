"""`twincell check`: the cell's self-check."""

from __future__ import annotations

from typing import Annotated

import typer


def check(
    json_file: Annotated[
        str | None, typer.Option("--json", help="Also write the figures to this JSON file.")
    ] = None,
) -> None:
    """Self-check of the cell: physics, FK/IK, tool changes, table, laser. Exit 0 if all hold."""
    from rich.console import Console

    from cell.sim.selfcheck import render, run_check, write_json

    report = run_check()
    Console().print(render(report))
    if json_file is not None:
        write_json(report, json_file)
    if not report.passed:
        raise typer.Exit(1)
