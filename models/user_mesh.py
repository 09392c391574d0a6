"""A user's mesh file (.stl, .obj, .ply) as a virtual model: loaded, scaled to metres, checked.

The full mesh serves rays and registration; a very large mesh is decimated before its convex
pieces for contact are computed. Files that are missing, empty, corrupt or not meshes, and
meshes with NaN vertices, raise `MeshFileError` / `MeshDataError` naming the file and the
problem. A size that looks like the wrong units raises (far off) or warns (borderline).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import igl
import numpy as np
import trimesh

from models.convex import convex_pieces
from models.mesh import TriangleMesh, component_labels
from models.model import ObjectModel
from models.model_errors import MeshDataError, MeshFileError
from models.units import unit_scale

MESH_SUFFIXES = (".stl", ".obj", ".ply")
# Plausible sizes [m] of an object in a robot cell: outside WARN a warning, outside FAIL an error.
SIZE_WARN = (0.01, 3.0)
SIZE_FAIL = (0.001, 20.0)
# Meshes with more faces than this are decimated to this many before the convex decomposition.
CONTACT_MAX_FACES = 20_000


@dataclass(frozen=True)
class LoadReport:
    """What was found in a mesh file: counts before cleaning, and the warnings."""

    path: str
    scale: float
    faces_in_file: int
    degenerate_faces_removed: int
    duplicate_faces_removed: int
    contact_faces: int
    warnings: tuple[str, ...]


def _read(path: Path) -> trimesh.Trimesh:
    if not path.exists():
        raise MeshFileError(f"{path}: no such file")
    if not path.is_file():
        raise MeshFileError(f"{path}: not a file")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise MeshFileError(f"{path}: not a mesh file (suffix {suffix!r}); valid: {MESH_SUFFIXES}")
    if path.stat().st_size == 0:
        raise MeshFileError(f"{path}: the file is empty")
    try:
        loaded = trimesh.load(path, file_type=suffix[1:], force="mesh", process=False)
    except Exception as exc:
        raise MeshFileError(f"{path}: cannot be read as {suffix[1:].upper()}: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshFileError(f"{path}: does not contain a triangle mesh")
    if len(loaded.faces) == 0:
        raise MeshFileError(
            f"{path}: contains no triangles ({len(loaded.vertices)} vertices): corrupt, or not a "
            "triangle mesh"
        )
    return loaded


def _setting(units_option: str, value: str) -> str:
    """The units setting as the user writes it: `--units mm` on a command line, `key: mm` in
    a configuration file."""
    return f"{units_option} {value}" if units_option.startswith("-") else f"{units_option}: {value}"


def _size_check(
    path: Path, extent: float, scale: float, warnings: list[str], units_option: str
) -> None:
    """Raise or warn when the largest extent [m] looks like the wrong units; the hint names
    `units_option` (the option or configuration key the units came from)."""
    hint = ""
    for name, s in (("mm", 1e-3), ("m", 1.0)):
        if s != scale and SIZE_WARN[0] <= extent / scale * s <= SIZE_WARN[1]:
            hint = f" (with {_setting(units_option, name)} it would be {extent / scale * s:.4g} m)"
            break
    message = f"{path}: largest extent {extent:.4g} m looks like the wrong units{hint}"
    if not SIZE_FAIL[0] <= extent <= SIZE_FAIL[1]:
        raise MeshDataError(message)
    if not SIZE_WARN[0] <= extent <= SIZE_WARN[1]:
        warnings.append(message)


def load_mesh_file(
    path: str | Path,
    units: str | float = "mm",
    contact_max_faces: int = CONTACT_MAX_FACES,
    units_option: str = "--units",
) -> tuple[ObjectModel, LoadReport]:
    """Load a .stl/.obj/.ply file as an `ObjectModel` in metres.

    `units` is "mm", "cm", "m", "in" or metres per file unit; `units_option` is where the user
    gave them (an option, or a configuration key), which a size that looks like the wrong
    units names in its hint. Duplicate vertices are merged,
    degenerate (zero-area) and duplicate faces removed. Warnings (open mesh, several parts,
    borderline size) are in the report; unusable input raises `MeshFileError`/`MeshDataError`.
    """
    path = Path(path)
    scale = unit_scale(units)
    loaded = _read(path)
    vertices = np.asarray(loaded.vertices, dtype=np.float64)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise MeshDataError(
            f"{path}: {int(bad.sum())} of {len(vertices)} vertices are NaN or infinite"
        )
    faces_in_file = len(loaded.faces)
    mesh = trimesh.Trimesh(vertices * scale, np.asarray(loaded.faces), process=False)
    mesh.merge_vertices()
    area_tol = (1e-9 * float(mesh.extents.max())) ** 2
    keep = mesh.area_faces > area_tol
    degenerate = int((~keep).sum())
    mesh.update_faces(keep)
    before = len(mesh.faces)
    mesh.update_faces(mesh.unique_faces())
    duplicates = before - len(mesh.faces)
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise MeshDataError(f"{path}: all {faces_in_file} triangles are degenerate (zero area)")

    warnings: list[str] = []
    _size_check(path, float(mesh.extents.max()), scale, warnings, units_option)
    if not mesh.is_watertight:
        warnings.append(
            f"{path}: the mesh is not watertight (open or non-manifold): fine for rays and "
            "registration; its volume and contact pieces are approximate"
        )
    if mesh.is_watertight and mesh.volume < 0:
        mesh.invert()
        warnings.append(f"{path}: the faces were oriented inwards; flipped")
    components = int(component_labels(mesh).max()) + 1
    if components > 1:
        warnings.append(f"{path}: the mesh has {components} separate parts")
    if degenerate:
        warnings.append(f"{path}: removed {degenerate} degenerate (zero-area) faces")
    if duplicates:
        warnings.append(f"{path}: removed {duplicates} duplicate faces")

    full = TriangleMesh.from_trimesh(mesh)
    contact = full
    edge_manifold = np.bincount(mesh.edges_unique_inverse).max() <= 2
    if len(mesh.faces) > contact_max_faces and edge_manifold:  # libigl needs a manifold
        v, f, _, _ = igl.decimate(
            np.asfortranarray(mesh.vertices),
            np.asfortranarray(mesh.faces, dtype=np.int32),
            contact_max_faces,
        )
        contact = TriangleMesh(v, f)
    model = ObjectModel(
        name=path.stem,
        mesh=full,
        convex_pieces=convex_pieces(contact),
        source=str(path),
    )
    report = LoadReport(
        str(path), scale, faces_in_file, degenerate, duplicates, len(contact.faces), tuple(warnings)
    )
    return model, report
