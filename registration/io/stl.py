"""Binary STL files read by numpy: one record per triangle, its corners as three vertices
of their own (as trimesh reads an STL without processing it: vertex k of triangle t is
vertex 3 t + k). ASCII STL, and a binary file whose size disagrees with its triangle count,
are left to trimesh (`read_binary_stl` returns None)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from registration.rigid import Array

#: A binary STL: an 80-byte header, the triangle count (uint32), then per triangle its
#: normal, its three corners (float32) and a 2-byte attribute.
_HEADER = 84
_TRIANGLE = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def read_binary_stl(p: Path) -> tuple[Array, Array] | None:
    """Vertices (3 F, 3) [file units] and faces (F, 3) of a binary STL file, or None if it
    is not one (trimesh reads it)."""
    data = p.read_bytes()
    if len(data) < _HEADER:
        return None
    count = int(np.frombuffer(data, "<u4", 1, 80)[0])
    if len(data) != _HEADER + count * _TRIANGLE.itemsize:
        return None
    triangles = np.frombuffer(data, _TRIANGLE, count, _HEADER)
    vertices = triangles["corners"].reshape(-1, 3).astype(float)
    return vertices, np.arange(3 * count, dtype=np.int64).reshape(-1, 3)
