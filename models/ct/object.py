"""A CT volume as the object of a job: its bone model with contact pieces, and the plan made
on it as the operations' targets."""

from __future__ import annotations

from pathlib import Path

from models.convex import convex_pieces
from models.ct.bone import ISO_HU, bone_model
from models.ct.readers import read_volume
from models.ct.regular import MAX_GAP_MM
from models.ct.volume_plan import read_plan
from models.model import ObjectModel


def volume_object(
    path: str | Path,
    iso_hu: float = ISO_HU,
    plan: str | Path | None = None,
    seed: int = 0,
    voxel_mm: tuple[float, float, float] | None = None,
    max_gap_mm: float = MAX_GAP_MM,
) -> ObjectModel:
    """The bone of the volume at `path` (threshold `iso_hu` [HU]) as an object model in the
    volume's frame [m], with the plan at `plan` (a JSON in the volume's frame, read_plan) as
    its burr holes, none if no plan. An irregular series is resampled (at `voxel_mm` if
    given; read_volume) and its `source` says how, and names the files of a series folder
    that were left out."""
    volume = read_volume(path, voxel_mm, max_gap_mm)
    bone = bone_model(volume, iso_hu=iso_hu)
    holes = () if plan is None else read_plan(plan, volume)
    name = Path(path).name.split(".")[0] or "ct"
    return ObjectModel(
        name=name,
        mesh=bone.mesh,
        convex_pieces=convex_pieces(bone.mesh, seed=seed),
        burr_holes=holes,
        source=f"CT {path} (bone at {iso_hu:g} HU)"
        + ("" if volume.resampled is None else f"; {volume.resampled}")
        + ("" if volume.skipped is None else f"; {volume.skipped}"),
    )
