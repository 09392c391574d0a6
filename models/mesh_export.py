"""Writing a model's mesh to STL, OBJ or PLY, completely or not at all."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from models.atomic import write_bytes
from models.mesh import TriangleMesh
from models.model_errors import MeshFileError
from models.units import unit_scale
from models.user_mesh import MESH_SUFFIXES


def write_mesh(mesh: TriangleMesh, path: str | Path, units: str | float = "mm") -> Path:
    """Write `mesh` [m] to `path` (.stl binary, .obj or .ply binary) in `units` (default mm,
    what 3D printers expect). Written to a temporary file beside `path` and then renamed, so
    that `path` is either the complete new file or untouched. Returns the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise MeshFileError(f"{path}: cannot write suffix {suffix!r}; valid: {MESH_SUFFIXES}")
    if not path.parent.is_dir():
        raise MeshFileError(f"{path}: the folder {path.parent} does not exist")
    scale = unit_scale(units)
    out = trimesh.Trimesh(np.asarray(mesh.vertices) / scale, np.asarray(mesh.faces), process=False)
    data = out.export(file_type=suffix[1:])
    if isinstance(data, dict):  # a format that exports several files: not one of ours
        raise MeshFileError(f"{path}: {suffix} exports more than one file")
    payload = data.encode() if isinstance(data, str) else data
    try:
        return write_bytes(path, payload)
    except OSError as exc:
        raise MeshFileError(f"{path}: cannot write: {exc}") from None
