"""`twincell author JOB --touch NAME=X,Y,Z ...`: a touch program written on the job's virtual
cell (its work object, its tool's data, an approach and a touch per named surface point, each
checked in the virtual cell), or with `--numbers` the cell's frames and numbers."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from scenarios.cli.help_format import argument, flag, option
from scenarios.cli.progress_lines import progress_lines
from scenarios.cli.run_command import CellOption
from scenarios.scenario_errors import ScenarioError

TOUCHES = "Touches"
OUTPUT = "Output"

EXAMPLES = (
    "twincell author examples/my_cell/job.yaml --cell examples/my_cell/cell.yaml "
    "--touch crown=-6.8,0.16,76.4 --touch brow=62.5,0.85,55.1 "
    "--touch temple=-0.74,-48.6,56.9 --out my_touches.mod",
    "twincell author skull --numbers",
)

_TOUCH = re.compile(r"^\s*([A-Za-z][A-Za-z0-9_]*)\s*=\s*([^@]+?)\s*(?:@\s*(.+?))?\s*$")


class TouchSyntaxError(ScenarioError, ValueError):
    """A --touch that does not read as NAME=X,Y,Z[@DX,DY,DZ]."""


def _triple(text: str, what: str, given: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        values = np.empty(0)
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        raise TouchSyntaxError(
            f"--touch {given!r}: the {what} must be three numbers X,Y,Z, got {text!r}"
        )
    return values


def parse_touch(text: str, scale_m: float) -> tuple[str, np.ndarray, np.ndarray | None]:
    """NAME, the point [m] (its coordinates times `scale_m`) and the direction (or None) of
    a --touch NAME=X,Y,Z[@DX,DY,DZ]."""
    match = _TOUCH.match(text)
    if match is None:
        raise TouchSyntaxError(
            f"--touch {text!r}: write NAME=X,Y,Z (a point of the part, the model's frame and "
            "units) or NAME=X,Y,Z@DX,DY,DZ (and the direction the tool moves into the part); "
            "a NAME starts with a letter and holds letters, digits and _"
        )
    name, point, direction = match.groups()
    p = _triple(point, "point", text) * scale_m
    if direction is None:
        return name, p, None
    d = _triple(direction, "direction", text)
    if np.linalg.norm(d) == 0.0:
        raise TouchSyntaxError(f"--touch {text!r}: the direction must not be zero")
    return name, p, d


JobArgument = Annotated[str, argument("JOB", "A shipped job (skull, assembly) or a CONFIG.yaml.")]
TouchOption = Annotated[
    list[str] | None,
    option(
        "--touch",
        "NAME=X,Y,Z[@DX,DY,DZ]",
        "A touch: a point of the part in its model's frame and units (the mesh file's; "
        "--units), and optionally the direction the tool moves into the part (default: along "
        "the surface's inward normal); repeatable, in the program's order.",
        TOUCHES,
    ),
]
UnitsOption = Annotated[
    str | None,
    option(
        "--units", "[mm|m]", "Units of the points (default: the job's cell.object.units).", TOUCHES
    ),
]
ApproachOption = Annotated[
    float,
    option(
        "--approach",
        "MM",
        "How far back along the tool's axis the approach lies [mm].",
        TOUCHES,
        min=0.1,
        max=300.0,
    ),
]
GapOption = Annotated[
    float,
    option(
        "--gap",
        "MM",
        "How far before the surface the tip ball stops [mm].",
        TOUCHES,
        min=0.0,
        max=50.0,
    ),
]
TableOption = Annotated[
    float,
    option(
        "--table", "MM", "The table's position the program is taught at (axis A) [mm].", TOUCHES
    ),
]
ModuleOption = Annotated[str, option("--module", "NAME", "The RAPID module's name.", OUTPUT)]
OutOption = Annotated[Path, option("--out", "FILE", "The RAPID module written.", OUTPUT)]
NumbersOption = Annotated[
    bool, flag("--numbers", "Print the cell's frames and numbers (Markdown) and exit.", OUTPUT)
]
QuietOption = Annotated[bool, flag("--quiet", "No progress lines.", OUTPUT)]


def author(
    job: JobArgument,
    touch: TouchOption = None,
    cell: CellOption = None,
    units: UnitsOption = None,
    approach: ApproachOption = 60.0,
    gap: GapOption = 1.0,
    table: TableOption = 0.0,
    module: ModuleOption = "Touches",
    out: OutOption = Path("touches.mod"),
    numbers: NumbersOption = False,
    quiet: QuietOption = False,
) -> None:
    """Write a touch program checked in the job's virtual cell.

    The RAPID module holds the job's tool (tooldata), the work object on the part's nominal
    pose (uframe; oframe identity) and, per --touch, an approach and a touch whose tip ball
    stops --gap before the surface: each solved on the cell's nominal arm and followed in the
    virtual cell before it is written (the tool spun about its axis where it must be). Run it
    with `twincell run JOB --program FILE`. With --numbers: the cell's frames and numbers.
    """
    from models.atomic import write_text
    from scenarios.configuration.config_files import load_config
    from scenarios.configuration.job_config import JobConfig
    from scenarios.jobs.cell_numbers import cell_numbers, numbers_markdown
    from scenarios.jobs.program_authoring import TouchRequest, author_program

    config = load_config(job, None, cell)
    if not isinstance(config, JobConfig):
        raise ScenarioError(f"{job!r} is not a job of the cell (the paper's is not)")
    if numbers:
        typer.echo(numbers_markdown(cell_numbers(config)), nl=False)
        return
    scale = {"mm": 1e-3, "m": 1.0}.get(units or config.cell.object.units)
    if scale is None:
        raise TouchSyntaxError(f"--units {units!r}: the units are mm or m")
    requests = [TouchRequest(*parse_touch(text, scale)) for text in touch or []]
    program = author_program(
        config, requests, approach * 1e-3, gap * 1e-3, table * 1e-3, module, progress_lines(quiet)
    )
    write_text(out, program.text)  # whole or not at all
    for t in program.touches:
        typer.echo(
            f"{t.touch_name}: the surface at "
            + ", ".join(f"{v * 1e3:.2f}" for v in t.p_surface_m)
            + " mm, the tool along "
            + ", ".join(f"{v:.3f}" for v in t.axis)
            + f", spun {t.spin_deg:+.0f} deg"
        )
    typer.echo(program.check.summary.replace("the corrected program", "the program"))
    cell_part = "" if cell is None else f" --cell {cell}"
    typer.echo(f"wrote {out}; run it with: twincell run {job}{cell_part} --program {out}")
