"""Approximate nearest-sample lookup on a voxel grid, for the coarse stages of the search.

Each voxel stores the index of the surface sample nearest to its centre, so a query is an
index computation and a gather: thousands of starts are scored in milliseconds. The sample
returned for a point is at most half a voxel diagonal farther than its true nearest sample;
the exact closest-point operator takes over in the refinement.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from registration.rigid import Array


class VoxelLookup:
    """Nearest surface sample per voxel over the padded bounding box of the samples.

    Args:
        samples: surface points (M, 3).
        tree: KD-tree over the samples.
        cells: voxels along the longest side of the padded box.
        pad: padding of the box on each side, as a fraction of the sample extent; points
            outside the box, or farther than `pad` from every sample, have no neighbour.
    """

    def __init__(self, samples: Array, tree: cKDTree, cells: int = 64, pad: float = 0.15) -> None:
        lo, hi = samples.min(axis=0), samples.max(axis=0)
        extent = float(np.linalg.norm(hi - lo))
        self.reach = pad * extent
        self.origin = lo - self.reach
        size = hi - lo + 2 * self.reach
        self.h = float(size.max() / cells)
        self.shape = np.maximum(np.ceil(size / self.h).astype(int), 1)
        axes = [self.origin[i] + (np.arange(self.shape[i]) + 0.5) * self.h for i in range(3)]
        centers = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        _, idx = tree.query(centers, workers=-1, distance_upper_bound=self.reach)
        self.index = np.where(idx < len(samples), idx, -1).astype(np.int32)
        self.samples = samples

    def query(self, points: Array) -> tuple[Array, Array]:
        """Approximate nearest samples for points (..., 3).

        Returns:
            distances (...) to the returned samples (inf where there is none) and their
            indices (...) (-1 where there is none).
        """
        cell = np.floor((points - self.origin) / self.h).astype(np.int64)
        inside = np.all((cell >= 0) & (cell < self.shape), axis=-1)
        cell = np.where(inside[..., None], cell, 0)
        flat = (cell[..., 0] * self.shape[1] + cell[..., 1]) * self.shape[2] + cell[..., 2]
        idx = np.where(inside, self.index[flat], -1)
        d = np.linalg.norm(points - self.samples[np.maximum(idx, 0)], axis=-1)
        return np.where(idx >= 0, d, np.inf), idx
