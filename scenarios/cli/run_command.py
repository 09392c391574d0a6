"""`twincell run`: a job run headless into a run folder, and the configuration keys its options
set."""

from __future__ import annotations

import os
from typing import Annotated

import typer

# The options of `twincell run` that take a paragraph to explain.
_FaultOption = Annotated[
    list[str] | None,
    typer.Option(
        "--fault",
        help="NAME[=AMOUNT[:OPTION]]: inject a fault into the real cell (see --list-faults), "
        "the amount in SI units; repeatable.",
    ),
]
_ModelOption = Annotated[
    str | None,
    typer.Option(
        "--model",
        help="Replace the job's object by this mesh (.stl, .obj, .ply) or CT volume (a "
        "DICOM series folder, .nii/.nii.gz, .nrrd/.nhdr: its bone).",
    ),
]
_TargetsOption = Annotated[
    str | None,
    typer.Option(
        "--targets",
        help="The object's targets: a targets YAML, or for a CT volume the plan made on "
        "it (plan.json: entry and target points in the volume's frame, mm).",
    ),
]
_ProgramOption = Annotated[
    str | None,
    typer.Option(
        "--program",
        help="Your RAPID module (.mod) written for the virtual cell, or a folder of the "
        "task's modules: its work object's robtargets become the operations, and the run "
        "writes it back corrected.",
    ),
]
_CellOption = Annotated[
    str | None,
    typer.Option(
        "--cell",
        help="The cell to run the job in: a shipped cell (ur5: the UR5 of "
        "example-robot-data, the rack placed for its reach) or a cell YAML (robot file, "
        "flange, mount, rack).",
    ),
]
_SetOption = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        help="KEY=VALUE: set any configuration value by its dotted key (e.g. "
        "cell.noise.laser_sigma_m=2e-4, calibration.enabled=false); repeatable.",
    ),
]


def run(
    name: Annotated[
        str | None,
        typer.Argument(help="A shipped job (paper, skull, assembly) or a CONFIG.yaml file."),
    ] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, help="Seed of all random draws.")
    ] = None,
    out: Annotated[str, typer.Option("--out", help="Folder that holds the run folders.")] = "runs",
    fault: _FaultOption = None,
    list_faults: Annotated[
        bool, typer.Option("--list-faults", help="List the faults and exit.")
    ] = False,
    model: _ModelOption = None,
    units: Annotated[str, typer.Option("--units", help="Units of --model: mm or m.")] = "mm",
    targets: _TargetsOption = None,
    program: _ProgramOption = None,
    cell: _CellOption = None,
    assign: _SetOption = None,
    spawn: Annotated[bool, typer.Option("--spawn", help="Show the run in a rerun viewer.")] = False,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write run.rrd.")] = False,
    no_cache: Annotated[
        bool,
        typer.Option(
            "--no-cache",
            help="Build the skull phantom and plan the scan anew instead of reading them from "
            "the user's cache folder (TWINCELL_NO_CACHE=1 does the same).",
        ),
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Run a job headless and write a run folder (results, table, figures, recording)."""
    from rich.console import Console

    from scenarios.jobs.runner import RunOptions, run_job

    if list_faults:
        _print_faults()
        return
    if name is None:
        raise typer.BadParameter("give a job (skull, assembly, paper) or a CONFIG.yaml")
    if no_cache:
        os.environ["TWINCELL_NO_CACHE"] = "1"  # models.cache; campaign workers inherit it

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    overrides = run_overrides(
        model=model, units=units, targets=targets, program=program, assign=assign, fault=fault
    )
    folder, result = run_job(
        name,
        seed=seed,
        out=out,
        progress=progress,
        overrides=overrides,
        options=RunOptions(rrd=not no_rrd, spawn=spawn),
        cell=cell,
    )
    from scenarios.results.run import RunResult

    if not isinstance(result, RunResult):  # the paper's experiments
        typer.echo(result.table)
        typer.echo(f"run folder: {folder}")
        return
    from scenarios.results.result_table import results_table

    Console().print(results_table(result))
    typer.echo(f"run folder: {folder}")
    if result.status == "at_risk":
        typer.echo(f"twincell: the program ran, but {result.reason}", err=True)
        raise typer.Exit(6)
    if result.status in ("refused", "aborted"):
        typer.echo(f"twincell: {result.status} in {result.stage}: {result.reason}", err=True)
        raise typer.Exit(3 if result.status == "refused" else 4)


def run_overrides(
    *,
    model: str | None,
    units: str,
    targets: str | None,
    program: str | None,
    assign: list[str] | None,
    fault: list[str] | None,
) -> dict[str, object]:
    """The dotted configuration keys `twincell run`'s options set: the object's model and
    units, its targets file, the program, each `--set KEY=VALUE` and each `--fault`."""
    from scenarios.configuration.config_files import fault_assignment, parse_assignment

    overrides: dict[str, object] = {}
    if model is not None:
        overrides |= {"cell.object.model": model, "cell.object.units": units}
    if targets is not None:
        overrides["cell.object.targets_file"] = targets
    if program is not None:
        overrides["operations.program"] = program
    overrides |= dict(parse_assignment(text) for text in assign or [])
    overrides |= dict(fault_assignment(text) for text in fault or [])
    return overrides


def _print_faults() -> None:
    """The fault kinds of the real cell, as a table."""
    from rich.console import Console
    from rich.table import Table

    from cell.sim.faults import FAULT_KINDS

    table = Table(title="faults of the real cell (--fault NAME[=AMOUNT[:OPTION]])")
    for column in ("fault", "what happens", "amount", "default", "stage", "option"):
        table.add_column(column)
    for k in FAULT_KINDS.values():
        table.add_row(
            k.name,
            k.what,
            f"{k.amount} \\[{k.unit}]",
            f"{k.default:g}",
            k.stage or "start",
            " | ".join(k.options) or "-",
        )
    Console(width=160).print(table)
