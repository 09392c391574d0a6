"""`twincell model`: a model checked and exported: a built-in model, a mesh file, or a CT
volume's bone surface."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from scenarios.cli.help_format import argument, flag, option


def _volume_model(
    path: str, iso: float, units: str, out: str | None, voxel_mm: str | None, max_gap_mm: float
) -> Any:
    """`twincell model` on a CT volume: its bone surface, checked, exported (returned: the
    mesh); an irregular series resampled (and said so)."""
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
    return bone.mesh


def _placement(up_axis: str, roll: float, pitch: float, yaw: float | None) -> Any:
    """The nominal placement of --up-axis, --roll, --pitch, --yaw (None: a job's default
    heading); a bad value is one line naming its option."""
    from pydantic import ValidationError

    from scenarios.configuration.config_error import ConfigError
    from scenarios.configuration.config_files import describe_validation_error
    from scenarios.offline.settings import NominalPlacement

    given = {"up_axis": up_axis, "roll_deg": roll, "pitch_deg": pitch}
    try:
        return NominalPlacement(**given, **({} if yaw is None else {"yaw_deg": yaw}))
    except ValidationError as exc:
        text = describe_validation_error(exc)
        for key, name in (("up_axis", "up-axis"), ("roll_deg", "roll"), ("pitch_deg", "pitch")):
            text = text.replace(f"{key}: ", f"--{name}: ")
        raise ConfigError(text) from None


def _on_table(vertices: Any, faces: Any, name: str, placement: Any, picture: Path | None) -> None:
    """How the mesh (vertices (N, 3) [m]) lies on the table at `placement`: its extents in the
    table frame printed, its picture written to `picture` (None: not)."""
    from rich.console import Console
    from rich.table import Table

    from registration import transform_points
    from scenarios.offline.nominal_placement import nominal_pose
    from scenarios.outputs.placement_figure import write_placement_figure

    T_table_object = nominal_pose(placement, vertices)
    p = transform_points(T_table_object, vertices) * 1e3
    pl = placement
    how = (
        f"up {pl.up_axis}, roll {pl.roll_deg:g}, pitch {pl.pitch_deg:g}, yaw {pl.yaw_deg:g} deg, "
        f"lowest point {pl.lift_m * 1e3:g} mm above the top"
    )
    typer.echo(f"on the table: {how}")
    table = Table(title="extents on the table")
    table.add_column("table axis", style="bold")
    table.add_column("from .. to \\[mm]", justify="right")
    table.add_column("size \\[mm]", justify="right")
    for k, axis in enumerate("xyz"):
        lo, hi = float(p[:, k].min()), float(p[:, k].max())
        table.add_row(axis, f"{lo:.1f} .. {hi:.1f}", f"{hi - lo:.1f}")
    Console().print(table)
    if picture is None:
        typer.echo("(--picture FILE or --out draws the part on the table)")
        return
    write_placement_figure(picture, vertices, faces, T_table_object, f"{name} on the table: {how}")
    typer.echo(f"wrote {picture} (the part on the table, from above and from two sides)")


def _picture_path(out: str | None, picture: str | None) -> Path | None:
    """Where the picture goes: --picture (a .png in a folder that exists), else beside --out
    (None: neither given)."""
    from scenarios.scenario_errors import ScenarioError

    if picture is None:
        return None if out is None else Path(out).with_name(f"{Path(out).stem}_on_table.png")
    path = Path(picture)
    if path.suffix.lower() != ".png":
        raise ScenarioError(f"--picture: the picture is a .png file, got {picture!r}")
    if not path.parent.is_dir():
        raise ScenarioError(f"--picture {picture}: the folder {path.parent} does not exist")
    return path


# The help's panels of `twincell model`.
MODEL = "Model"
CT = "CT volume"
PLACEMENT = "On the table (a job's cell.object.placement)"
OUTPUT = "Output"

EXAMPLES = (
    "twincell model skull --out skull.stl",
    "twincell model examples/my_cell/phantom.ply --units mm --real",
    "twincell model model.stl --up-axis +y --yaw 90 --picture on_table.png",
)


NameArgument = Annotated[
    str,
    argument(
        "NAME",
        "A built-in model (skull, bracket, housing, lid, ellipsoid), a mesh file (.stl, "
        ".obj, .ply), or a CT volume (a DICOM series folder, .nii/.nii.gz, .nrrd/.nhdr) "
        "whose bone surface is segmented and meshed.",
    ),
]
RealOption = Annotated[
    bool, flag("--real", "The real entity: the model plus its model error.", MODEL)
]
SeedOption = Annotated[
    int, option("--seed", "INTEGER", "Seed of the skull's shape and the model error.", MODEL, min=0)
]
UnitsOption = Annotated[
    str, option("--units", "[mm|m]", "Units of a mesh file and of --out.", MODEL)
]
IsoOption = Annotated[float, option("--iso", "FLOAT", "Bone threshold [HU].", CT)]
VoxelOption = Annotated[
    str | None,
    option(
        "--voxel-mm",
        "SIZE",
        "Resample the volume onto a regular grid of this voxel size [mm] (one size or "
        "AxBxC). Default: a series with uneven slice steps or a gantry tilt is resampled at "
        "its pixel spacing and smallest step, a regular one kept.",
        CT,
    ),
]
MaxGapOption = Annotated[
    float,
    option(
        "--max-gap-mm",
        "FLOAT",
        "The widest step between the series' slices that is interpolated over [mm]; wider "
        "is refused as missing slices.",
        CT,
    ),
]
UpAxisOption = Annotated[
    str,
    option(
        "--up-axis",
        "[+x|-x|+y|-y|+z|-z]",
        "The model's axis that points up, away from the table (placement.up_axis).",
        PLACEMENT,
    ),
]
RollOption = Annotated[
    float, option("--roll", "DEG", "Then turned about the table's x [deg].", PLACEMENT)
]
PitchOption = Annotated[
    float, option("--pitch", "DEG", "Then turned about the table's y [deg].", PLACEMENT)
]
YawOption = Annotated[
    float | None,
    option(
        "--yaw",
        "DEG",
        "Then turned about the table's vertical [deg]. Default: a job's, 120.",
        PLACEMENT,
    ),
]
OutOption = Annotated[
    str | None, option("--out", "FILE", "Write the mesh to this .stl/.obj/.ply file.", OUTPUT)
]
PictureOption = Annotated[
    str | None,
    option(
        "--picture",
        "FILE",
        "Write the picture of the part on the table to this .png file. Default: with "
        "--out, OUT_on_table.png beside it.",
        OUTPUT,
    ),
]


def model(
    name: NameArgument,
    real: RealOption = False,
    seed: SeedOption = 0,
    units: UnitsOption = "mm",
    iso: IsoOption = 300.0,
    voxel_mm: VoxelOption = None,
    max_gap_mm: MaxGapOption = 10.0,
    up_axis: UpAxisOption = "+z",
    roll: RollOption = 0.0,
    pitch: PitchOption = 0.0,
    yaw: YawOption = None,
    out: OutOption = None,
    picture: PictureOption = None,
) -> None:
    """Check a model and export it: built in, a mesh file or a CT volume.

    Prints the model's vertices, faces, whether it is watertight, its size, volume and convex
    pieces; of a CT volume, the bone surface segmented at --iso and meshed (an irregular series
    resampled, and said so). Then how it lies on the table at a job's nominal placement
    (--up-axis, --roll, --pitch, --yaw): its extents in the table frame, and with --picture
    (or beside --out) a picture of it on the table top from above and from two sides. --out
    writes the mesh.
    """
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from models.check import check_model
    from models.ct.readers import is_volume
    from models.mesh_export import write_mesh
    from models.registry import load_model

    placement = _placement(up_axis, roll, pitch, yaw)
    where = _picture_path(out, picture)
    if is_volume(name):
        bone = _volume_model(name, iso, units, out, voxel_mm, max_gap_mm)
        _on_table(bone.vertices, bone.faces, name, placement, where)
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
    _on_table(loaded.mesh.vertices, loaded.mesh.faces, report.name, placement, where)
