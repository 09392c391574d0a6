"""`twincell check`: the cell's self-check."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from scenarios.cli.help_format import option

if TYPE_CHECKING:
    from cell.sim.selfcheck import CheckReport

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

    from cell.sim.selfcheck import render, run_check

    report = run_check()
    Console().print(render(report))
    if json_file is not None:
        write_json(report, json_file)
    if not report.passed:
        raise typer.Exit(1)


def write_json(report: CheckReport, path: str | Path) -> None:
    """Write the report's figures and whether it `passed` as JSON, completely or not at all
    (temporary file, then rename)."""
    from cell.cell_errors import CellConfigError
    from models.atomic import write_text
    from scenarios.results.json_converter import unstructure

    path = Path(path)
    if not path.parent.is_dir():
        raise CellConfigError(
            f"cannot write the check report to {str(path)!r}: folder {str(path.parent)!r} "
            "does not exist"
        )
    data = unstructure(report) | {"passed": report.passed}
    write_text(path, json.dumps(data, indent=2) + "\n")
