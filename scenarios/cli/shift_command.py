"""`twincell shift`: one real cell through a shift of jobs, its arm warming as it works, the
calibration checked, kept or made anew by a policy."""

from __future__ import annotations

from typing import Annotated, cast

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
    str,
    option(
        "--policy",
        "[check|once|every]",
        "What each job does with the calibration: check the last one on the spheres and "
        "calibrate anew only where the cell moved (check), keep the first job's unchecked "
        "(once), or calibrate every job (every).",
        SHIFT,
    ),
]


def shift(
    name: Annotated[str, argument("JOB", "A shipped cell job (skull, assembly) or a CONFIG.yaml.")],
    jobs: Annotated[int, option("--jobs", "N", "Jobs in the shift.", SHIFT, min=1)] = 12,
    hours: Annotated[
        float,
        option("--hours", "H", "The shift's length on the cell's clock [h].", SHIFT, min=0.01),
    ] = 4.0,
    policy: PolicyOption = "check",
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
    from scenarios.results.shift_result import Policy

    lines = progress_lines(quiet)

    def say(message: str) -> None:
        if verbose or not message.startswith("[job "):
            lines(message)

    overrides = run_overrides(
        model=None, units="mm", targets=None, program=None, assign=assign, fault=None
    )
    # ShiftOptions refuses a policy not in POLICIES, naming the valid ones
    options = ShiftOptions(jobs=jobs, hours=hours, policy=cast(Policy, policy), rrd=rrd)
    folder, result = run_shift(name, seed, out, say, overrides, cell, options)
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
