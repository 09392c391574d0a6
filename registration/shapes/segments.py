"""A model given as a set of segments (eq. 13-14): exact closest point by AABB tree."""

from __future__ import annotations

import igl
import numpy as np

from registration.registration_errors import InputError
from registration.rigid import Array
from registration.shapes.base import Closest, Shape, check_points


class SegmentModel(Shape):
    """Model as segments: vertices (V, 3) and index pairs (S, 2)."""

    def __init__(self, vertices: Array, segments: Array, samples_per_length: float = 0.0) -> None:
        self.vertices = check_points(vertices, "segment vertices", minimum=2)
        seg = np.asarray(segments)
        if seg.ndim != 2 or seg.shape[1] != 2 or len(seg) == 0:
            raise InputError(f"segments must be an (S, 2) index array, S >= 1; got {seg.shape}")
        if seg.min() < 0 or seg.max() >= len(self.vertices):
            raise InputError(
                f"segment indices must lie in [0, {len(self.vertices) - 1}]; got "
                f"[{seg.min()}, {seg.max()}]"
            )
        self.segments = np.ascontiguousarray(seg, dtype=np.int64)
        self._tree = igl.AABB()
        self._tree.init(self.vertices, self.segments)
        a, b = self.vertices[self.segments[:, 0]], self.vertices[self.segments[:, 1]]
        u = np.linspace(0.0, 1.0, 9)[:, None, None]
        self.samples = (a + u * (b - a)).reshape(-1, 3)
        self.sample_normals = None

    def closest(self, points: Array) -> Closest:
        p = np.ascontiguousarray(points, dtype=float)
        d2, _, c = self._tree.squared_distance(self.vertices, self.segments, p)
        return Closest(c, None, np.sqrt(d2))
