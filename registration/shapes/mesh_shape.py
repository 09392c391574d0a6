"""A model given as a triangle mesh (eq. 15-16): exact closest point by libigl's AABB tree.

libigl's AABB (C++) answers exact point-triangle queries about 50x faster than
trimesh.proximity. The normals are the closest triangles' face normals, or the offset's
direction where the closest point lies on an edge or a vertex. The tree is built on the
first exact query: the coarse search needs only the surface sample.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import igl
import numpy as np

from registration.registration_errors import InputError
from registration.rigid import Array
from registration.shapes.base import Closest, Shape, check_points


def sample_surface(
    vertices: Array, faces: Array, count: int, seed: int = 0, cross: Array | None = None
) -> tuple[Array, Array]:
    """Area-weighted random points on a triangle mesh and their face normals, (count, 3) each.

    `cross` (F, 3), if given, is each face's (b - a) x (c - a), already computed."""
    if cross is None:
        a, b, c = (vertices[faces[:, i]] for i in range(3))
        cross = np.cross(b - a, c - a)
    area2 = np.linalg.norm(cross, axis=1)
    rng = np.random.default_rng(seed)
    cumulative = np.cumsum(area2)
    face = np.searchsorted(cumulative, rng.random(count) * cumulative[-1], side="right")
    face = np.minimum(face, len(faces) - 1)
    r1, r2 = rng.random(count), rng.random(count)
    s = np.sqrt(r1)
    u, v, w = 1.0 - s, s * (1.0 - r2), s * r2
    corners = vertices[faces[face]]  # (count, 3, 3): only the faces drawn
    pts = u[:, None] * corners[:, 0] + v[:, None] * corners[:, 1] + w[:, None] * corners[:, 2]
    normals = cross[face] / area2[face, None]
    return pts, normals


class MeshModel(Shape):
    """Model as a triangle mesh: vertices (V, 3), faces (F, 3) of vertex indices.

    Degenerate (zero-area) faces are ignored for normals; closest-point queries are exact.
    """

    has_normals = True
    oriented = True

    def __init__(self, vertices: Array, faces: Array, sample_count: int = 20000) -> None:
        self.vertices = check_points(vertices, "mesh vertices", minimum=3)
        f = np.asarray(faces)
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            raise InputError(f"mesh faces must be an (F, 3) index array, F >= 1; got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            raise InputError(f"mesh faces must hold integer vertex indices; got {f.dtype}")
        if f.min() < 0 or f.max() >= len(self.vertices):
            raise InputError(
                f"mesh face indices must lie in [0, {len(self.vertices) - 1}]; got "
                f"[{f.min()}, {f.max()}]"
            )
        self.faces = np.ascontiguousarray(f, dtype=np.int64)
        a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
        cross = np.cross(b - a, c - a)
        norm = np.linalg.norm(cross, axis=1)
        if not np.any(norm > 0):
            raise InputError("mesh has no face of positive area: every triangle is degenerate")
        self.face_normals = cross / np.where(norm > 0, norm, 1.0)[:, None]
        self.samples, self.sample_normals = sample_surface(
            self.vertices, self.faces, sample_count, cross=cross
        )

    @classmethod
    def restore(
        cls,
        vertices: Array,
        faces: Array,
        face_normals: Array,
        samples: Array,
        sample_normals: Array,
    ) -> MeshModel:
        """The model that a previous one computed these arrays for (registration.prepared
        stores them): vertices (V, 3), faces (F, 3) int64, unit face normals (F, 3), surface
        samples and their normals (M, 3). Neither checked nor recomputed: the caller has
        checked their shapes and values."""
        model = cls.__new__(cls)
        model.vertices, model.faces, model.face_normals = vertices, faces, face_normals
        model.samples, model.sample_normals = samples, sample_normals
        return model

    @classmethod
    def from_trimesh(cls, mesh: Any, sample_count: int = 20000) -> MeshModel:
        """Build from any object with `vertices` and `faces` (e.g. a trimesh.Trimesh)."""
        return cls(mesh.vertices, mesh.faces, sample_count)

    def __getstate__(self) -> dict[str, object]:
        # The tree stays behind (it does not pickle); the copy builds its own when needed.
        return {k: v for k, v in self.__dict__.items() if k != "tree"}

    @cached_property
    def tree(self) -> igl.AABB:
        """libigl's AABB tree over the triangles, built on first use."""
        tree = igl.AABB()
        tree.init(self.vertices, self.faces)
        return tree

    def closest(self, points: Array) -> Closest:
        p = np.ascontiguousarray(points, dtype=float)
        d2, face, c = self.tree.squared_distance(self.vertices, self.faces, p)
        distances = np.sqrt(d2)
        return Closest(c, _distance_gradient(p - c, self.face_normals[face]), distances)

    @cached_property
    def resolution(self) -> float:
        """Median edge length of the mesh [length units]."""
        v = self.vertices
        f = self.faces[:: max(1, len(self.faces) // 20000)]
        edges = np.concatenate([v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 1]]])
        return float(np.median(np.linalg.norm(edges, axis=1)))


def _distance_gradient(offset: Array, face_normals: Array) -> Array:
    """Unit normals (N, 3) for the offsets (N, 3) of points from their closest points: the
    face normal where the closest point lies inside the face (the offset is along it), the
    offset's direction (signed like the face normal) where it lies on an edge or a vertex.

    A point beyond a boundary edge is then as far from the model in point-to-plane terms as
    it is in space, so a scan cannot slide off the end of a flat face at no cost."""
    length = np.linalg.norm(offset, axis=1)
    along = np.einsum("nd,nd->n", offset, face_normals)
    across = np.linalg.norm(offset - along[:, None] * face_normals, axis=1)
    on_boundary = across > 1e-3 * length
    sign = np.where(along < 0.0, -1.0, 1.0)
    direction = offset * (sign / np.maximum(length, 1e-300))[:, None]
    return np.where(on_boundary[:, None], direction, face_normals)
