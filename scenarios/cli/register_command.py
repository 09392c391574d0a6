"""`twincell register DATA... MODEL`: data points registered to a model surface, one scan as a
table (and JSON), several as JSON Lines."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from scenarios.cli.help_format import argument, flag, option

if TYPE_CHECKING:
    from scenarios.cli.file_registration import MatchOptions


# The help's panels of `twincell register`.
INPUT = "Data and model"
SEARCH = "Search"
OUTPUT = "Output"

EXAMPLES = (
    "twincell register scan.ply model.stl --units mm --json result.json",
    "twincell register scans/*.ply model.twm --batch --json results.jsonl",
)

#: The register command's arguments and longer options (typer reads them from the types).
DataArgument = Annotated[
    list[str],
    argument(
        "DATA...",
        "Data points: .xyz, .txt, .pts, .csv, .npy, .ply, .pcd, .e57, .las or .laz. Several "
        "files: each is registered to the one model, one JSON line per file (a file that "
        "cannot be read is a line with its error).",
    ),
]
ModelArgument = Annotated[
    Path,
    argument(
        "MODEL",
        "Model: a mesh (.stl, .obj, .ply, .off), a point file, or a prepared model (.twm, "
        "from `twincell prepare`).",
        exists=True,
        dir_okay=False,
    ),
]
TargetsOption = Annotated[
    Path | None,
    option(
        "--targets",
        "FILE",
        "Targets in the model frame (JSON {name: [x, y, z]} or a point file, in the model's "
        "units): the verdict is then per target.",
        INPUT,
        exists=True,
        dir_okay=False,
    ),
]
ModeOption = Annotated[
    str,
    option(
        "--mode",
        "[auto|global|local|refine]",
        "auto (any coverage), global (data cover the whole model), local (part of it) or "
        "refine (ICP from --init, no search).",
        SEARCH,
    ),
]
InitOption = Annotated[
    Path | None,
    option(
        "--init",
        "FILE",
        "A guess of T_model_data (a 4 x 4 in .txt, .csv, .npy, or .json such as this "
        "command's --json output; translation in --units): the start of refine, one more "
        "start in the other modes.",
        SEARCH,
        exists=True,
        dir_okay=False,
    ),
]
JsonOption = Annotated[
    str | None,
    option(
        "--json",
        "FILE",
        "Write the result to this JSON file (several data files: their JSON Lines, one per "
        "file, instead of standard output).",
        OUTPUT,
    ),
]


def register(
    data: DataArgument,
    model: ModelArgument,
    units: Annotated[
        str, option("--units", "[m|mm]", "Units of the data (and of the model).", INPUT)
    ] = "m",
    model_units: Annotated[
        str | None,
        option(
            "--model-units",
            "[m|mm]",
            "Units of the model if not --units (a .twm keeps those it was prepared in).",
            INPUT,
        ),
    ] = None,
    targets: TargetsOption = None,
    noise: Annotated[
        float | None,
        option("--noise", "FLOAT", "The sensor's range noise (sigma), in --units.", INPUT, min=0.0),
    ] = None,
    mode: ModeOption = "auto",
    init: InitOption = None,
    seed: Annotated[int, option("--seed", "INTEGER", "Seed of the search.", SEARCH, min=0)] = 0,
    json_file: JsonOption = None,
    batch: Annotated[
        bool, flag("--batch", "JSON Lines output even for one data file.", OUTPUT)
    ] = False,
) -> None:
    """Register data points to a model: the transform and its quality.

    One data file: the transform T_model_data and its quality figures as a table (and as JSON
    with --json). With several data files, every file is registered to the one model in this
    process and each gives one JSON line (its result's fields, or its error): on standard
    output, or in the --json file with a summary line per file on standard output. A file that
    fails does not stop the others; the exit status is then 2.
    """
    from registration.io import load_pose, unit_scale
    from scenarios.cli.file_registration import MatchOptions, load_named_targets, model_units_of

    model_path = str(model)  # the file's name as the results and the messages give it
    named = None
    if targets is not None:
        named = load_named_targets(str(targets), model_units_of(model_path, units, model_units))
    noise_m = None if noise is None or noise == 0 else noise * unit_scale(units)
    T_init = None if init is None else load_pose(str(init), units)
    options = MatchOptions(mode, units, seed, named, noise_m, T_init)
    if len(data) == 1 and not batch:
        _register_one(data[0], model_path, options, model_units, json_file)
    else:
        _register_many(data, model_path, options, model_units, json_file)


def _register_one(
    data: str, model: str, options: MatchOptions, model_units: str | None, json_file: str | None
) -> None:
    """`twincell register DATA MODEL`: the result as a table, and as JSON with --json."""
    from scenarios.cli.file_registration import register_files, render_result, write_result_json

    result = register_files(data, model, options, model_units)
    render_result(result, options.targets)
    if json_file is not None:
        write_result_json(result, json_file, options.targets)


def _register_many(
    data: list[str],
    model: str,
    options: MatchOptions,
    model_units: str | None,
    json_file: str | None,
) -> None:
    """`twincell register DATA... MODEL`: one JSON line per data file, the model read once."""
    from scenarios.cli.file_registration import load_model_file, register_batch, write_batch

    options.check()
    shape = load_model_file(model, options.units, model_units)
    outcomes = register_batch(data, shape, model, options)
    if json_file is None:
        count = write_batch(outcomes, model, options.targets, sys.stdout)
    else:
        with open(json_file, "w") as lines:
            count = write_batch(outcomes, model, options.targets, lines, typer.echo)
    if count.failed or count.internal:
        typer.echo(
            f"twincell: error: {count.failed + count.internal} of {len(data)} data files "
            f"failed (their lines say why)",
            err=True,
        )
        raise typer.Exit(1 if count.internal else 2)
