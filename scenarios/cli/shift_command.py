"""`twincell shift`: one real cell through a shift of jobs, its arm warming as it works, the
calibration checked, kept or made anew by a policy."""

from __future__ import annotations

from typing import Annotated

import typer

from scenarios.cli.help_format import argument, flag, option
from scenarios.cli.progress_lines import progress_lines
from scenarios.cli.run_command import CellOption, SetOption, run_overrides

# The help's panels of `twincell shift`.
SHIFT = "Shift"
OUTPUT = "Output"

EXAMPLES = (
    "twincell shift skull --jobs 12 --hours 4",
    "twincell shift skull --jobs 12 --hours 4 --policy once --seed 3",
)

PolicyOption = Annotated[
    str | None,
    option(
        "--policy",
        "[check|once|every]",
        "What each job does with the calibration: check the last one on the spheres and "
        "calibrate anew only where the cell moved (check), keep the first job's unchecked "
        "(once), or calibrate every job (every). Default: the job's shift.policy (check).",
        SHIFT,
    ),
]


def shift(
    name: Annotated[str, argument("JOB", "A shipped cell job (skull, assembly) or a CONFIG.yaml.")],
    jobs: Annotated[
        int | None,
        option("--jobs", "N", "Jobs in the shift. Default: the job's shift.jobs (12).", SHIFT),
    ] = None,
    hours: Annotated[
        float | None,
        option(
            "--hours",
            "H",
            "The shift's length on the cell's clock [h]. Default: the job's shift.hours (4).",
            SHIFT,
        ),
    ] = None,
    policy: PolicyOption = None,
    seed: Annotated[
        int | None, option("--seed", "INTEGER", "The real cell (its seed).", SHIFT, min=0)
    ] = None,
    cell: CellOption = None,
    assign: SetOption = None,
    out: Annotated[
        str, option("--out", "DIR", "Folder that holds the shift folders.", OUTPUT)
    ] = "runs",
    rrd: Annotated[bool, flag("--rrd", "Write each job's run.rrd too.", OUTPUT)] = False,
    verbose: Annotated[bool, flag("--verbose", "Each job's progress lines too.", OUTPUT)] = False,
    quiet: Annotated[bool, flag("--quiet", "No progress lines.", OUTPUT)] = False,
) -> None:
    """Run a shift of jobs on one real cell and write a shift folder.

    Each job meets a part placed anew while the arm warms (shift.warmup_rad, shift.duty).
    The shift folder holds each job's run folder (jobs/), the table (shift.csv), the result
    (shift.json), the figure (shift.png) and the recording (shift.rrd, on the shift's
    clock). Exit status 1 when a job ended complete with a goal missed.
    """
    from scenarios.jobs.shift import ShiftOptions, run_shift

    lines = progress_lines(quiet)

    def say(message: str) -> None:
        if verbose or not message.startswith("[job "):
            lines(message)

    overrides = run_overrides(
        model=None, units="mm", targets=None, program=None, assign=assign, fault=None
    )
    # the job's shift section validates them, naming what is valid
    given = {"shift.jobs": jobs, "shift.hours": hours, "shift.policy": policy}
    overrides |= {key: value for key, value in given.items() if value is not None}
    folder, result = run_shift(name, seed, out, say, overrides, cell, ShiftOptions(rrd=rrd))
    mean = result.mean_cell_time_s
    statuses = ", ".join(f"{result.count(s)} {s}" for s in sorted({j.status for j in result.jobs}))
    typer.echo(f"shift of {len(result.jobs)} jobs ({statuses}); mean cell time per job "
               f"{'?' if mean is None else f'{mean:.0f} s'}")  # fmt: skip
    typer.echo(f"shift folder: {folder}")
    if result.missed_while_complete:
        typer.echo(
            f"twincell: {result.missed_while_complete} job(s) ended complete with a goal missed",
            err=True,
        )
        raise typer.Exit(1)
