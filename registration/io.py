"""Reading points and model surfaces from files, with errors that name the problem.

Points: .xyz / .txt (x y z per line, an optional first line holding the count, extra
columns ignored), .csv (comma separated, an optional header line), .npy ((N, 3) array),
.ply (vertices). Models: a triangle mesh (.stl, .obj, .ply with faces) or a point file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from registration.errors import FormatError
from registration.rigid import Array
from registration.shapes.base import Shape, check_points
from registration.shapes.mesh import MeshModel
from registration.shapes.points import PointModel

POINT_FORMATS: tuple[str, ...] = (".xyz", ".txt", ".csv", ".npy", ".ply")
MESH_FORMATS: tuple[str, ...] = (".stl", ".obj", ".ply")


def _existing(path: str | Path, valid: tuple[str, ...], what: str) -> Path:
    p = Path(path)
    if not p.is_file():
        raise FormatError(f"{what} file not found: {p}")
    if p.suffix.lower() not in valid:
        raise FormatError(
            f"{what} file {p} has unknown format {p.suffix or '(none)'!r}; valid: "
            f"{', '.join(valid)}"
        )
    return p


def _read_text(p: Path, delimiter: str | None) -> Array:
    rows: list[list[float]] = []
    lines = p.read_text(errors="replace").splitlines()
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        fields = text.split(delimiter) if delimiter else text.split()
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and number <= 1:
                continue  # a header line
            raise FormatError(
                f"{p}:{number}: expected numbers, got {line.strip()[:60]!r}"
            ) from None
        if not rows and len(values) == 1:
            continue  # the optional count line
        if len(values) < 3:
            raise FormatError(f"{p}:{number}: expected x y z, got {len(values)} value(s)")
        rows.append(values[:3])
    if not rows:
        raise FormatError(f"{p} holds no points")
    return np.asarray(rows, dtype=float)


def load_points(path: str | Path) -> Array:
    """Points (N, 3) from a point file; raises FormatError or InputError on bad content."""
    p = _existing(path, POINT_FORMATS, "points")
    suffix = p.suffix.lower()
    if suffix == ".npy":
        try:
            a = np.load(p, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise FormatError(f"{p} is not a readable .npy array: {exc}") from None
    elif suffix == ".ply":
        a = np.asarray(_load_trimesh(p).vertices, dtype=float)
    else:
        a = _read_text(p, "," if suffix == ".csv" else None)
    return check_points(a, f"points in {p}", minimum=1)


def _load_trimesh(p: Path) -> object:
    import trimesh

    try:
        return trimesh.load(p, force=None, process=False)
    except Exception as exc:  # trimesh raises many kinds on corrupt files
        raise FormatError(f"{p} could not be read as a mesh or point cloud: {exc}") from None


def load_model(path: str | Path, units_scale: float = 1.0) -> Shape:
    """A model Shape from a mesh file (.stl, .obj, .ply with faces) or a point file.

    Args:
        path: the file.
        units_scale: factor applied to the coordinates (e.g. 1e-3 for a mesh in mm).
    """
    p = _existing(path, tuple(dict.fromkeys(MESH_FORMATS + POINT_FORMATS)), "model")
    if p.suffix.lower() not in MESH_FORMATS:
        return PointModel(load_points(p) * units_scale)
    loaded = _load_trimesh(p)
    geometries = getattr(loaded, "geometry", None)  # a scene of several meshes
    if isinstance(geometries, dict):
        if not geometries:
            raise FormatError(f"mesh {p} is empty: no geometry")
        import trimesh

        loaded = trimesh.util.concatenate(list(geometries.values()))
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float)
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        if p.suffix.lower() == ".ply" and len(vertices) >= 3:
            return PointModel(vertices * units_scale)  # a point cloud in PLY
        raise FormatError(f"mesh {p} is empty: {len(vertices)} vertices and no faces")
    return MeshModel(vertices * units_scale, np.asarray(faces))
