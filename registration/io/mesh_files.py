"""Meshes and PLY files: .ply (points or triangles) and binary .stl by numpy
(registration.io.ply, registration.io.stl), .obj, .off and the files those readers leave
(ascii STL, polygons other than triangles, ...) by trimesh."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from registration.io.ply import read_ply
from registration.io.stl import read_binary_stl
from registration.registration_errors import FormatError, first_line
from registration.rigid import Array

MESH_FORMATS: tuple[str, ...] = (".stl", ".obj", ".ply", ".off")


def _ply_vertex_count(p: Path) -> int | None:
    """The vertex count a PLY header declares, or None if the header cannot be read."""
    with p.open("rb") as f:
        head = f.read(4096)
    if not head.startswith(b"ply"):
        raise FormatError(f"{p}: not a PLY file (it does not start with 'ply')")
    if b"end_header" not in head:
        return None
    for line in head.split(b"end_header", 1)[0].splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == b"element" and parts[1] == b"vertex":
            try:
                return int(parts[2])
            except ValueError:
                raise FormatError(f"{p}: a bad vertex count in the PLY header: {line!r}") from None
    return None


def _read_trimesh(p: Path) -> tuple[Array, Array | None]:
    """Vertices and faces (None for a point cloud) as trimesh reads them."""
    import trimesh

    try:
        loaded = trimesh.load(p, process=False)
    except Exception as exc:  # trimesh raises many kinds on corrupt files
        raise FormatError(
            f"{p}: cannot be read as {p.suffix[1:].upper()}: {first_line(exc)}"
        ) from None
    geometries = getattr(loaded, "geometry", None)  # a scene of several meshes
    if isinstance(geometries, dict):
        if not geometries:
            raise FormatError(f"{p}: the file is empty: no geometry")
        loaded = trimesh.util.concatenate(list(geometries.values()))
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float)
    faces = getattr(loaded, "faces", None)
    return vertices, None if faces is None else np.asarray(faces)


def read_mesh(p: Path, points_only: bool) -> tuple[Array, Array | None]:
    """Vertices (V, 3) and faces (F, 3) (None for a point cloud) of a mesh or PLY file.

    With `points_only`, a PLY range-scan mesh gives its vertices as the points.
    """
    suffix = p.suffix.lower()
    is_ply = suffix == ".ply"
    declared = _ply_vertex_count(p) if is_ply else None
    read: tuple[Array, Array | None] | None = None
    if is_ply:
        read = read_ply(p, faces=not points_only)
    elif suffix == ".stl":
        read = read_binary_stl(p)
    vertices, faces = read if read is not None else _read_trimesh(p)
    if declared is not None and len(vertices) != declared:
        raise FormatError(
            f"{p}: its header declares {declared} vertices but {len(vertices)} were read "
            f"(a truncated file?)"
        )
    if len(vertices) == 0:
        raise FormatError(f"{p}: the file is empty: no vertices")
    if points_only or faces is None or len(faces) == 0:
        if not points_only and not is_ply:
            raise FormatError(f"{p}: the mesh is empty: {len(vertices)} vertices and no faces")
        return vertices, None
    return vertices, faces
