"""`twincell prepare MODEL`: a model prepared once for many `twincell register` calls."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from scenarios.cli.help_format import argument, option

EXAMPLES = ("twincell prepare tests/data/stanford/dragon/model.ply --out dragon.twm",)


def prepare(
    model: Annotated[
        Path,
        argument(
            "MODEL",
            "Model: a mesh (.stl, .obj, .ply, .off) or a point file.",
            exists=True,
            dir_okay=False,
        ),
    ],
    out: Annotated[
        str | None,
        option(
            "--out",
            "FILE",
            "The prepared model file (.twm); default: MODEL with the suffix .twm.",
        ),
    ] = None,
    units: Annotated[str, option("--units", "[m|mm]", "Units of the model.")] = "m",
) -> None:
    """Prepare a model once for many `twincell register` calls.

    Its surface sample, voxel lookup, anchors and symmetries are written to a .twm file that
    `twincell register` reads back instead of the model.
    """
    import time

    from scenarios.cli.file_registration import model_summary, prepare_file

    model_path = str(model)  # the file's name as the messages give it
    t0 = time.perf_counter()
    written, shape = prepare_file(model_path, out, units)
    typer.echo(
        f"wrote {written} ({model_summary(shape)}; from {model_path} in {units}; "
        f"{written.stat().st_size / 1e6:.1f} MB; {time.perf_counter() - t0:.2f} s)"
    )
