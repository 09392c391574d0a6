"""Approximate nearest-sample lookup on a voxel grid, for the coarse stages of the search.

Each voxel stores the index of a surface sample near it, so a query is an index computation
and a gather: thousands of starts are scored in milliseconds. The grid is filled by a
Euclidean distance transform from the voxels that hold samples (each keeps one of its
samples), so the sample returned for a point lies in the occupied voxel nearest to it: at
most about one voxel diagonal farther than its true nearest sample. The exact closest-point
operator takes over in the refinement.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from registration.rigid import Array


class VoxelLookup:
    """Nearest surface sample per voxel over the padded bounding box of the samples.

    Args:
        samples: surface points (M, 3).
        cells: voxels along the longest side of the padded box.
        pad: padding of the box on each side, as a fraction of the sample extent; points
            outside the box, or farther than `pad` from every sample, have no neighbour.
    """

    def __init__(self, samples: Array, cells: int = 64, pad: float = 0.15) -> None:
        lo, hi = samples.min(axis=0), samples.max(axis=0)
        extent = float(np.linalg.norm(hi - lo))
        self.reach = pad * extent
        self.origin = lo - self.reach
        size = hi - lo + 2 * self.reach
        self.h = float(size.max() / cells)
        self.shape = np.maximum(np.ceil(size / self.h).astype(int), 1)
        cell = np.clip(
            np.floor((samples - self.origin) / self.h).astype(np.int64), 0, self.shape - 1
        )
        flat = np.ravel_multi_index(cell.T, self.shape)
        owner = np.full(int(np.prod(self.shape)), -1, dtype=np.int64)
        # The last sample written to a voxel keeps it: any one of its samples will do.
        owner[flat] = np.arange(len(samples))
        empty = (owner < 0).reshape(self.shape)
        distance, nearest = ndimage.distance_transform_edt(empty, return_indices=True)
        index = owner[np.ravel_multi_index(nearest.reshape(3, -1), self.shape)]
        gap = distance.ravel() * self.h
        far = gap > self.reach
        index[far] = -1
        self.index = index.astype(np.int32)
        # Distance from each voxel to the nearest voxel holding a sample, for scoring.
        self.gap = np.where(far, np.inf, gap).astype(np.float32)
        self.samples = samples

    def _flat(self, points: Array) -> Array:
        """Flat voxel index (...) of points (..., 3); -1 outside the box."""
        cell = np.floor((points - self.origin) * (1.0 / self.h)).astype(np.int32)
        inside = np.all((cell >= 0) & (cell < self.shape), axis=-1)
        flat = (cell[..., 0] * self.shape[1] + cell[..., 1]) * self.shape[2] + cell[..., 2]
        return np.where(inside, flat, -1)

    def distance(self, points: Array) -> Array:
        """Approximate distances (...) of points (..., 3) to the surface sample: the distance
        from their voxel to the nearest voxel holding a sample (inf where there is none).
        Within about one voxel diagonal of the truth; for scoring many poses at once."""
        flat = self._flat(points)
        return np.where(flat >= 0, self.gap[np.maximum(flat, 0)], np.float32(np.inf))

    def query(self, points: Array) -> tuple[Array, Array]:
        """Approximate nearest samples for points (..., 3).

        Returns:
            distances (...) to the returned samples (inf where there is none) and their
            indices (...) (-1 where there is none).
        """
        flat = self._flat(points)
        idx = np.where(flat >= 0, self.index[np.maximum(flat, 0)], -1)
        d = np.linalg.norm(points - self.samples[np.maximum(idx, 0)], axis=-1)
        return np.where(idx >= 0, d, np.inf), idx
