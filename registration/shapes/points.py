"""A model given as a set of points (eq. 12): closest point by KD-tree."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from registration.rigid import Array
from registration.shapes.base import Closest, Shape, check_points, estimate_normals


class PointModel(Shape):
    """Model set X as points (N, 3).

    Normals (N, 3) are optional; without them they are estimated (unoriented) for dense sets
    of at least `dense` points, which then allow point-to-plane ICP. Sparse sets have no
    normals and are matched point to point, as in the seed paper.
    """

    def __init__(
        self,
        points: Array,
        normals: Array | None = None,
        workers: int = -1,
        dense: int = 2000,
    ) -> None:
        points = check_points(points, "model points", minimum=3)
        if normals is None:
            if len(points) >= dense:
                normals = estimate_normals(points)
        else:
            normals = check_points(normals, "model normals")
            normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        self._set(points, normals, workers)

    def _set(self, points: Array, normals: Array | None, workers: int) -> None:
        self.points = points
        self.samples = self.points
        self.workers = workers
        self._tree = cKDTree(self.points)
        self.sample_tree = self._tree
        self.sample_normals = normals
        self.has_normals = normals is not None

    @classmethod
    def restore(cls, points: Array, normals: Array | None, workers: int = -1) -> PointModel:
        """The model that a previous one built from these points (N, 3) with these unit
        normals (N, 3) or None (registration.prepared stores them): the normals are neither
        estimated nor normalised again, the points not checked again."""
        model = cls.__new__(cls)
        model._set(points, normals, workers)  # noqa: SLF001 - the class's own constructor
        return model

    def closest(self, points: Array) -> Closest:
        # Threads pay off only for large batches: their start-up costs about a millisecond.
        workers = self.workers if len(points) > 20000 else 1
        d, i = self._tree.query(points, workers=workers)
        normals = None if self.sample_normals is None else self.sample_normals[i]
        return Closest(self.points[i], normals, d)
