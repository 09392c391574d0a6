"""What every model shape offers to the matcher: the C operator and a surface sample.

Each shape answers two closest-point questions:
- `closest(points)`: the exact C operator of the seed paper (points, segments, triangles,
  the parametric surface itself);
- `near(points)`: a fast one for points already near the surface, used while a pose is
  still moving: the nearest surface sample and its tangent plane. Point-to-plane ICP on it
  converges to within the sample spacing times the surface's curvature of the exact
  answer; the matcher always finishes with `closest`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from registration.kernels import Kernel
from registration.lookup import VoxelLookup
from registration.registration_errors import InputError
from registration.rigid import Array
from registration.starts import farthest_point_sample, local_frame


@dataclass(frozen=True)
class Closest:
    """Closest points on a shape to query points.

    Attributes:
        points: closest points (N, 3).
        normals: unit normals at those points (N, 3), or None if the shape has none.
        distances: Euclidean distances (N,) [length units].
        found: (N,) False where a search bounded by a reach found no surface (the point
            and distance are then placeholders at the reach), or None if every point has
            its closest point.
    """

    points: Array
    normals: Array | None
    distances: Array
    found: Array | None = None

    def weights(self, residuals: Array, kernel: Kernel) -> Array:
        """The kernel's weights (N,) of the residuals (N,) of the points that found the
        surface (the robust scale is theirs alone: placeholders at the reach, if they are
        more than half, would make it zero), and zero for the others."""
        if self.found is None:
            return kernel.weights(residuals)
        w = np.zeros(len(residuals))
        if self.found.any():
            w[self.found] = kernel.weights(residuals[self.found])
        return w


def check_points(points: Array, what: str, minimum: int = 1) -> Array:
    """Validate an (N, 3) array of finite numbers with N >= minimum; returns float64 copy."""
    try:
        a = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what} must be an (N, 3) array of numbers: {exc}") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{what} must be an (N, 3) array; got shape {a.shape}")
    if len(a) < minimum:
        raise InputError(f"{what} needs at least {minimum} points; got {len(a)}")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise InputError(
            f"{what} holds {int(bad.sum())} point(s) with NaN or inf (first at row "
            f"{int(np.flatnonzero(bad)[0])}); all coordinates must be finite"
        )
    return np.ascontiguousarray(a)


class Shape:
    """Base of the model shapes: a surface sample (for coarse search) and the C operator.

    Subclasses set `samples` (M, 3) and `sample_normals` (M, 3) or None, and implement
    `closest`. Normals may be unoriented (sign arbitrary) for point sets.
    """

    samples: Array
    sample_normals: Array | None
    has_normals: bool = False
    #: True if the normals point outward consistently (meshes, parametric surfaces).
    oriented: bool = False

    def closest(self, points: Array) -> Closest:  # pragma: no cover - interface
        raise TypeError(f"{type(self).__name__} does not implement closest()")

    def near(self, points: Array, reach: float = np.inf) -> Closest:
        """Closest surface sample and its tangent plane, for points (N, 3) near the surface.

        The point-to-plane residual n . (p - q) is the distance to the sample's tangent
        plane; `distances` are to the sample itself. Shapes whose samples are the model
        (point sets) answer exactly. A point with no sample within `reach` is given one at
        `reach` along its normal: its residual is `reach` (far points are outliers; the
        bounded search is faster).
        """
        # Threads pay off only for large batches: their start-up costs about a millisecond.
        workers = -1 if len(points) > 2000 else 1
        d, i = self.sample_tree.query(points, distance_upper_bound=reach, workers=workers)
        missing = i >= len(self.samples)
        i = np.where(missing, 0, i)
        q = self.samples[i]
        normals = None if self.sample_normals is None else self.sample_normals[i]
        if missing.any():
            q = q.copy()
            if normals is None:
                q[missing] = points[missing] + np.array([reach, 0.0, 0.0])
            else:
                q[missing] = points[missing] - reach * normals[missing]
            d = np.where(missing, reach, d)
        return Closest(q, normals, d, None if not missing.any() else ~missing)

    def closest_within(self, points: Array, reach: float) -> Closest:
        """The exact closest points for points (N, 3) within about `reach` of the surface (by
        the nearest sample); the others keep the answer of `near` (residual >= reach)."""
        fast = self.near(points, reach)
        inside = fast.distances < reach
        if not inside.any():
            return fast
        exact = self.closest(points[inside])
        q = fast.points.copy()
        q[inside] = exact.points
        d = fast.distances.copy()
        d[inside] = exact.distances
        normals = fast.normals
        if normals is not None and exact.normals is not None:
            normals = normals.copy()
            normals[inside] = exact.normals
        return Closest(q, normals, d, fast.found)

    @cached_property
    def sample_tree(self) -> cKDTree:
        """KD-tree over the surface sample, for the vectorised coarse search."""
        return cKDTree(self.samples)

    def anchor_frames(self, count: int, radius: float) -> tuple[Array, Array]:
        """Well-spread surface anchors (count, 3) and their local frames (count, 3, 3), cached.

        The frames' third column is the surface normal by PCA within `radius` (see
        registration.starts.local_frame).
        """
        cache = self.anchor_cache()
        key = (count, radius)
        if key not in cache:
            # Thinnings of the sample: 4,000 points give as good normals and 2,000 as well
            # spread farthest points, five and ten times faster.
            pool = self.samples[:: max(1, len(self.samples) // 4000)]
            spread = pool[:: max(1, len(pool) // 2000)]
            anchors = spread[farthest_point_sample(spread, count)]
            cache[key] = (anchors, local_frame(pool, anchors, radius))
        return cache[key]

    def anchor_cache(self) -> dict[tuple[int, float], tuple[Array, Array]]:
        """The anchors and frames computed so far, by (count, radius): what `anchor_frames`
        returns again, and what a prepared-model file stores (registration.prepared)."""
        cache: dict[tuple[int, float], tuple[Array, Array]] = self.__dict__.setdefault(
            "_anchor_cache", {}
        )
        return cache

    @cached_property
    def sample_lookup(self) -> VoxelLookup:
        """Voxel lookup of the nearest surface sample, for scoring many starts at once."""
        return VoxelLookup(self.samples)

    @cached_property
    def extent(self) -> float:
        """Diagonal of the axis-aligned bounding box of the surface [length units]."""
        return float(np.linalg.norm(np.ptp(self.samples, axis=0)))

    @cached_property
    def centroid(self) -> Array:
        """Centroid of the surface sample (3,)."""
        return self.samples.mean(axis=0)

    @cached_property
    def resolution(self) -> float:
        """The finest detail the model represents [length units]: the median spacing of its
        surface sample (meshes: of their vertices along edges)."""
        d, _ = self.sample_tree.query(self.samples[:: max(1, len(self.samples) // 2000)], k=2)
        return float(np.median(d[:, 1]))


def estimate_normals(points: Array, k: int = 12) -> Array:
    """Unoriented unit normals (N, 3) by principal components of the k nearest neighbours."""
    k = int(min(k, len(points)))
    _, idx = cKDTree(points).query(points, k=k)
    nb = points[idx] - points[idx].mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb)
    _, vecs = np.linalg.eigh(cov)
    return vecs[:, :, 0]
