"""`twincell model`: a model checked and exported: a built-in model, a mesh file, or a CT
volume's bone surface."""

from __future__ import annotations

from typing import Annotated

import typer

from scenarios.cli.help_format import argument, flag, option


def _volume_model(
    path: str, iso: float, units: str, out: str | None, voxel_mm: str | None, max_gap_mm: float
) -> None:
    """`twincell model` on a CT volume: its bone surface, checked, exported; an irregular
    series resampled (and said so)."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from models.ct import bone_model, read_volume
    from models.ct.regular import voxel_size
    from models.mesh_export import write_mesh

    volume = read_volume(path, voxel_size(voxel_mm), max_gap_mm)
    if volume.resampled is not None:
        typer.echo(f"{path}: {volume.resampled}")
    if volume.skipped is not None:
        typer.echo(f"twincell: warning: {volume.skipped}", err=True)
    bone = bone_model(volume, iso_hu=iso)
    c = bone.check
    table = Table(title=f"bone model: {path}", show_header=False)
    table.add_column("item", style="bold")
    table.add_column("value")
    rows = (
        ("modality / frame", f"{volume.modality or 'not stated'} / {volume.native_frame}"),
        ("voxels (i, j, k)", " x ".join(str(n) for n in volume.data.shape)),
        ("grid", "the file's own" if volume.resampled is None else str(volume.resampled)),
        ("files skipped", "none" if volume.skipped is None else str(volume.skipped)),
        ("voxel size (i, j, k) \\[mm]", ", ".join(f"{v:.3f}" for v in c.voxel_mm)),
        ("threshold \\[HU]", f"{c.iso_hu:g}"),
        ("faces", str(c.faces)),
        ("watertight", "yes" if c.watertight else "no"),
        ("volume \\[cm^3]", "-" if c.volume_m3 is None else f"{c.volume_m3 * 1e6:.2f}"),
        ("from the isosurface, mean / max \\[mm]",
         f"{c.deviation_mean_m * 1e3:.3f} / {c.deviation_max_m * 1e3:.3f}"),
    )  # fmt: skip
    for label, value in rows:
        table.add_row(label, Text(value))  # Text: a file's name is not markup
    Console().print(table)
    if out is not None:
        written = write_mesh(bone.mesh, out, units)
        typer.echo(f"wrote {written} ({len(bone.mesh.faces)} triangles, {units})")


# The help's panels of `twincell model`.
MODEL = "Model"
CT = "CT volume"
OUTPUT = "Output"

EXAMPLES = (
    "twincell model skull --out skull.stl",
    "twincell model examples/my_cell/phantom.ply --units mm --real",
)


def model(
    name: Annotated[
        str,
        argument(
            "NAME",
            "A built-in model (skull, bracket, housing, lid, ellipsoid), a mesh file (.stl, "
            ".obj, .ply), or a CT volume (a DICOM series folder, .nii/.nii.gz, .nrrd/.nhdr) "
            "whose bone surface is segmented and meshed.",
        ),
    ],
    real: Annotated[
        bool, flag("--real", "The real entity: the model plus its model error.", MODEL)
    ] = False,
    seed: Annotated[
        int,
        option("--seed", "INTEGER", "Seed of the skull's shape and the model error.", MODEL, min=0),
    ] = 0,
    units: Annotated[
        str, option("--units", "[mm|m]", "Units of a mesh file and of --out.", MODEL)
    ] = "mm",
    iso: Annotated[float, option("--iso", "FLOAT", "Bone threshold [HU].", CT)] = 300.0,
    voxel_mm: Annotated[
        str | None,
        option(
            "--voxel-mm",
            "SIZE",
            "Resample the volume onto a regular grid of this voxel size [mm] (one size or "
            "AxBxC). Default: a series with uneven slice steps or a gantry tilt is resampled at "
            "its pixel spacing and smallest step, a regular one kept.",
            CT,
        ),
    ] = None,
    max_gap_mm: Annotated[
        float,
        option(
            "--max-gap-mm",
            "FLOAT",
            "The widest step between the series' slices that is interpolated over [mm]; wider "
            "is refused as missing slices.",
            CT,
        ),
    ] = 10.0,
    out: Annotated[
        str | None,
        option("--out", "FILE", "Write the mesh to this .stl/.obj/.ply file.", OUTPUT),
    ] = None,
) -> None:
    """Check a model and export it: built in, a mesh file or a CT volume.

    Prints the model's vertices, faces, whether it is watertight, its size, volume and convex
    pieces; of a CT volume, the bone surface segmented at --iso and meshed (an irregular series
    resampled, and said so). --out writes the mesh.
    """
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from models.check import check_model
    from models.ct.readers import is_volume
    from models.mesh_export import write_mesh
    from models.registry import load_model

    if is_volume(name):
        _volume_model(name, iso, units, out, voxel_mm, max_gap_mm)
        return

    loaded, warnings = load_model(name, real=real, seed=seed, units=units)
    report = check_model(loaded, warnings)
    table = Table(title=f"model check: {report.name}", show_header=False)
    table.add_column("item", style="bold")
    table.add_column("value")
    for label, value in report.rows():
        table.add_row(Text(label), Text(value))  # Text: "[mm]" is not markup
    Console().print(table)
    for warning in report.warnings:
        typer.echo(f"twincell: warning: {warning}", err=True)
    if out is not None:
        written = write_mesh(loaded.mesh, out, units)
        typer.echo(f"wrote {written} ({len(loaded.mesh.faces)} triangles, {units})")
