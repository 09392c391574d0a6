"""`twincell run`: a job run headless into a run folder, and the configuration keys its options
set."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from scenarios.cli.help_format import argument, flag, option
from scenarios.cli.progress_lines import progress_lines

# The help's panels of `twincell run`.
JOB = "Job"
CELL = "Cell"
FAULTS = "Faults and overrides"
OUTPUT = "Output"
RECORDING = "Recording"
CONTROLLER = "Controller"

EXAMPLES = (
    "twincell run skull --cell ur5 --seed 3",
    "twincell run skull --fault object_bump --set calibration.enabled=false",
)

# The options of `twincell run` that take a paragraph to explain.
ModelOption = Annotated[
    Path | None,
    option(
        "--model",
        "PATH",
        "Replace the job's object by this mesh (.stl, .obj, .ply) or CT volume (a DICOM series "
        "folder, .nii/.nii.gz, .nrrd/.nhdr: its bone).",
        JOB,
        exists=True,
    ),
]
TargetsOption = Annotated[
    Path | None,
    option(
        "--targets",
        "FILE",
        "The object's targets: a targets YAML, or for a CT volume the plan made on it "
        "(plan.json: entry and target points in the volume's frame, mm).",
        JOB,
        exists=True,
        dir_okay=False,
    ),
]
ProgramOption = Annotated[
    Path | None,
    option(
        "--program",
        "PATH",
        "Your RAPID module (.mod) written for the virtual cell, or a folder of the task's "
        "modules: its work object's robtargets become the operations, and the run writes it "
        "back corrected.",
        JOB,
        exists=True,
    ),
]
NoCacheOption = Annotated[
    bool,
    flag(
        "--no-cache",
        "Build the skull phantom and plan the scan anew instead of reading them from the "
        "user's cache folder (TWINCELL_NO_CACHE=1 does the same).",
        JOB,
    ),
]
CellOption = Annotated[
    str | None,
    option(
        "--cell",
        "CELL",
        "The cell to run the job in: a shipped cell (ur5: the UR5 of example-robot-data, the "
        "rack placed for its reach) or a cell YAML (robot file, flange, mount, rack).",
        CELL,
    ),
]
FaultOption = Annotated[
    list[str] | None,
    option(
        "--fault",
        "NAME[=AMOUNT[:OPTION]]",
        "Inject a fault into the real cell (see --list-faults), the amount in SI units; "
        "repeatable.",
        FAULTS,
    ),
]
SetOption = Annotated[
    list[str] | None,
    option(
        "--set",
        "KEY=VALUE",
        "Set any configuration value by its dotted key (e.g. cell.noise.laser_sigma_m=2e-4, "
        "calibration.enabled=false); repeatable.",
        FAULTS,
    ),
]


ControllerOption = Annotated[
    str | None,
    option(
        "--controller",
        "URL",
        "Run the job on this controller's Robot Web Services (http://HOST:PORT): a real "
        "IRC5, or twincell serve. The user and password come from TWINCELL_RWS_USER and "
        "TWINCELL_RWS_PASSWORD, or the file TWINCELL_RWS_CREDENTIALS names.",
        CONTROLLER,
    ),
]
EgmPortOption = Annotated[
    int | None,
    option(
        "--egm-port",
        "PORT",
        "This computer's UDP port the controller's EGM stream comes to.",
        CONTROLLER,
        min=1,
        max=65535,
    ),
]
ProfilesOption = Annotated[
    str | None,
    option("--profiles", "HOST:PORT", "The line laser's profile stream.", CONTROLLER),
]

CommissioningOption = Annotated[
    Path | None,
    option(
        "--commissioning",
        "FILE",
        "The cell's commissioning record from an earlier run on it (its commissioning.json): "
        "the TCP checks compare with it instead of reading the tool at the beam anew.",
        CELL,
        exists=True,
        dir_okay=False,
    ),
]

CalibrationOption = Annotated[
    Path | None,
    option(
        "--calibration",
        "FILE",
        "The cell's calibration from an earlier run on it (its calibration.json): the job "
        "checks it on a few views of the spheres and keeps it, instead of calibrating, where "
        "the cell has not moved (refused if made on another cell or more than "
        "calibration.max_age_h ago).",
        CELL,
        exists=True,
        dir_okay=False,
    ),
]


def run(
    name: Annotated[
        str | None, argument("JOB", "A shipped job (paper, skull, assembly) or a CONFIG.yaml file.")
    ] = None,
    seed: Annotated[
        int | None, option("--seed", "INTEGER", "Seed of all random draws.", JOB, min=0)
    ] = None,
    model: ModelOption = None,
    units: Annotated[str, option("--units", "[mm|m]", "Units of --model.", JOB)] = "mm",
    targets: TargetsOption = None,
    program: ProgramOption = None,
    no_cache: NoCacheOption = False,
    cell: CellOption = None,
    commissioning: CommissioningOption = None,
    calibration: CalibrationOption = None,
    fault: FaultOption = None,
    list_faults: Annotated[
        bool, flag("--list-faults", "List the faults and exit.", FAULTS)
    ] = False,
    assign: SetOption = None,
    out: Annotated[
        str, option("--out", "DIR", "Folder that holds the run folders.", OUTPUT)
    ] = "runs",
    quiet: Annotated[bool, flag("--quiet", "No progress lines.", OUTPUT)] = False,
    spawn: Annotated[bool, flag("--spawn", "Show the run in a rerun viewer.", RECORDING)] = False,
    no_rrd: Annotated[bool, flag("--no-rrd", "Do not write run.rrd.", RECORDING)] = False,
    controller: ControllerOption = None,
    egm_port: EgmPortOption = None,
    profiles: ProfilesOption = None,
) -> None:
    """Run a job headless and write a run folder.

    The run folder holds the results (results.json), the table, the figures and the recording
    (run.rrd). Exit status 3 when the job refuses, 4 when it aborts, 6 when the program ran but
    its goal is at risk.
    """
    from scenarios.jobs.runner import RunOptions, run_job

    if list_faults:
        _print_faults()
        return
    if name is None:
        raise typer.BadParameter("give a job (skull, assembly, paper) or a CONFIG.yaml")
    overrides = run_overrides(
        model=model, units=units, targets=targets, program=program, assign=assign, fault=fault
    )
    address = _address(controller, egm_port, profiles)
    folder, result = run_job(
        name,
        seed=seed,
        out=out,
        progress=progress_lines(quiet),
        overrides=overrides,
        options=RunOptions(
            rrd=not no_rrd,
            spawn=spawn,
            cache=not no_cache,
            controller=address,
            commissioning=commissioning,
            calibration=calibration,
        ),
        cell=cell,
    )
    _report(folder, result)


def _report(folder: Path, result: Any) -> None:
    """The run's table and folder; for a cell job that did not complete, why, and the exit
    status that says so (6 at risk, 3 refused, 4 aborted)."""
    from rich.console import Console

    from scenarios.results.result_table import results_table
    from scenarios.results.run import RunResult

    if not isinstance(result, RunResult):  # the paper's experiments
        typer.echo(result.table)
        typer.echo(f"run folder: {folder}")
        return
    Console().print(results_table(result))
    typer.echo(f"run folder: {folder}")
    if result.status == "at_risk":
        typer.echo(f"twincell: the program ran, but {result.reason}", err=True)
        raise typer.Exit(6)
    if result.status in ("refused", "aborted"):
        typer.echo(f"twincell: {result.status} in {result.stage}: {result.reason}", err=True)
        raise typer.Exit(3 if result.status == "refused" else 4)


def _address(controller: str | None, egm_port: int | None, profiles: str | None) -> Any:
    """The controller across the network the job runs on, or None (the job's own cell)."""
    if controller is None:
        return None
    from scenarios.jobs.network_job import ControllerAddress

    return ControllerAddress.parse(controller, egm_port, profiles)


def run_overrides(
    *,
    model: str | Path | None,
    units: str,
    targets: str | Path | None,
    program: str | Path | None,
    assign: list[str] | None,
    fault: list[str] | None,
) -> dict[str, object]:
    """The dotted configuration keys `twincell run`'s options set: the object's model and
    units, its targets file, the program (a path as its text), each `--set KEY=VALUE` and
    each `--fault`."""
    from scenarios.configuration.config_files import fault_assignment, parse_assignment

    overrides: dict[str, object] = {}
    if model is not None:
        overrides |= {"cell.object.model": str(model), "cell.object.units": units}
    if targets is not None:
        overrides["cell.object.targets_file"] = str(targets)
    if program is not None:
        overrides["operations.program"] = str(program)
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
