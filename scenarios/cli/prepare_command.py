"""`twincell prepare MODEL`: a model prepared once for many `twincell register` calls."""

from __future__ import annotations

from typing import Annotated

import typer


def prepare(
    model: Annotated[
        str,
        typer.Argument(help="Model: a mesh (.stl, .obj, .ply, .off) or a point file."),
    ],
    out: Annotated[
        str | None,
        typer.Option(
            "--out", help="The prepared model file (.twm); default: MODEL with the suffix .twm."
        ),
    ] = None,
    units: Annotated[str, typer.Option("--units", help="Units of the model: m or mm.")] = "m",
) -> None:
    """Prepare a model once for many `twincell register` calls: its surface sample, voxel
    lookup, anchors and symmetries, written to a .twm file that `register` reads back."""
    import time

    from scenarios.cli.file_registration import model_summary, prepare_file

    t0 = time.perf_counter()
    written, shape = prepare_file(model, out, units)
    typer.echo(
        f"wrote {written} ({model_summary(shape)}; from {model} in {units}; "
        f"{written.stat().st_size / 1e6:.1f} MB; {time.perf_counter() - t0:.2f} s)"
    )
