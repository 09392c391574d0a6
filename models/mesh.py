"""The triangle mesh value: vertices in metres and triangle indices, checked when built."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from models.model_errors import MeshDataError


def component_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    """Connected component of each face (faces sharing an edge are connected), (M,) int."""
    return trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, copy=True)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A triangle mesh: `vertices` (N, 3) float [m], `faces` (M, 3) int indices into vertices.

    The arrays are copied and made read-only. Raises `MeshDataError` on wrong shapes, NaN or
    infinite vertices, indices out of range, or an empty mesh.
    """

    vertices: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        vertices = np.asarray(self.vertices)
        faces = np.asarray(self.faces)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
            raise MeshDataError(f"vertices must have shape (N, 3) with N > 0, got {vertices.shape}")
        if not np.issubdtype(vertices.dtype, np.number):
            raise MeshDataError(f"vertices must be numbers, got dtype {vertices.dtype}")
        vertices = vertices.astype(np.float64)
        bad = ~np.isfinite(vertices).all(axis=1)
        if bad.any():
            raise MeshDataError(
                f"{int(bad.sum())} of {len(vertices)} vertices are NaN or infinite "
                f"(first at index {int(np.flatnonzero(bad)[0])})"
            )
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise MeshDataError(f"faces must have shape (M, 3) with M > 0, got {faces.shape}")
        if not np.issubdtype(faces.dtype, np.integer):
            raise MeshDataError(f"faces must be integer indices, got dtype {faces.dtype}")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise MeshDataError(
                f"face indices must lie in [0, {len(vertices) - 1}], "
                f"got [{int(faces.min())}, {int(faces.max())}]"
            )
        object.__setattr__(self, "vertices", _frozen(vertices))
        object.__setattr__(self, "faces", _frozen(faces.astype(np.int64)))

    @property
    def extents(self) -> np.ndarray:
        """Size of the axis-aligned bounding box, (3,) [m]."""
        return np.ptp(self.vertices, axis=0)

    def to_trimesh(self) -> trimesh.Trimesh:
        """A trimesh copy of this mesh (no vertex merging, no processing)."""
        return trimesh.Trimesh(
            vertices=np.array(self.vertices), faces=np.array(self.faces), process=False
        )

    @classmethod
    def from_trimesh(cls, mesh: trimesh.Trimesh) -> TriangleMesh:
        """The value of a trimesh's vertices [m] and faces."""
        return cls(vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces))
