"""Approximate nearest-sample lookup on a voxel grid, for the coarse stages of the search.

Each voxel stores the index of a surface sample near it, so a query is an index computation
and a gather: thousands of starts are scored in milliseconds. The grid is filled by a
Euclidean distance transform from the voxels that hold samples (each keeps one of its
samples), so the sample returned for a point lies in the occupied voxel nearest to it: at
most about one voxel diagonal farther than its true nearest sample. The exact closest-point
operator takes over in the refinement.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration.rigid import Array


@dataclass(frozen=True)
class VoxelGrid:
    """Where a lookup's voxels lie: the corner `origin` (3,) of voxel (0, 0, 0), the voxel
    side `h`, the voxel counts `shape` (3,) and the `reach` beyond which no sample is a
    neighbour [length units]."""

    origin: Array
    h: float
    shape: Array
    reach: float


class VoxelLookup:
    """Nearest surface sample per voxel over the padded bounding box of the samples.

    Args:
        samples: surface points (M, 3).
        cells: voxels along the longest side of the padded box.
        pad: padding of the box on each side, as a fraction of the sample extent; points
            outside the box, or farther than `pad` from every sample, have no neighbour.
    """

    def __init__(self, samples: Array, cells: int = 64, pad: float = 0.15) -> None:
        from scipy import ndimage  # here: a restored lookup does not need it

        lo, hi = samples.min(axis=0), samples.max(axis=0)
        extent = float(np.linalg.norm(hi - lo))
        self.reach = pad * extent
        size = hi - lo + 2 * self.reach
        self.h = float(size.max() / cells)
        # One more layer of voxels on every side, empty and far: a point outside the box is
        # clipped onto it, so a query needs no inside test.
        self.origin = lo - self.reach - self.h
        inner = np.maximum(np.ceil(size / self.h).astype(int), 1)
        self.shape = inner + 2
        cell = np.clip(np.floor((samples - self.origin) / self.h).astype(np.int64), 1, inner)
        flat = np.ravel_multi_index(cell.T, self.shape)
        owner = np.full(int(np.prod(self.shape)), -1, dtype=np.int64)
        # The last sample written to a voxel keeps it: any one of its samples will do.
        owner[flat] = np.arange(len(samples))
        empty = (owner < 0).reshape(self.shape)
        distance, nearest = ndimage.distance_transform_edt(empty, return_indices=True)
        index = owner[np.ravel_multi_index(nearest.reshape(3, -1), self.shape)]
        gap = distance * self.h
        border = np.ones(self.shape, dtype=bool)
        border[1:-1, 1:-1, 1:-1] = False
        far = (gap > self.reach) | border
        index[far.ravel()] = -1
        grid = VoxelGrid(self.origin, self.h, self.shape, self.reach)
        # Distance from each voxel to the nearest voxel holding a sample, for scoring.
        self._set(samples, grid, index, np.where(far, np.inf, gap).ravel())

    def _set(self, samples: Array, grid: VoxelGrid, index: Array, gap: Array) -> None:
        self.origin, self.h, self.shape, self.reach = grid.origin, grid.h, grid.shape, grid.reach
        self.index = np.ascontiguousarray(index, dtype=np.int32)
        self.gap = np.ascontiguousarray(gap, dtype=np.float32)
        self.samples = samples
        self._last = (self.shape - 1).astype(np.int32)
        self._strides = np.array([self.shape[1] * self.shape[2], self.shape[2], 1], np.int32)

    @classmethod
    def restore(cls, samples: Array, grid: VoxelGrid, index: Array, gap: Array) -> VoxelLookup:
        """The lookup that was built over `samples` (M, 3), from its grid and its voxels'
        sample indices and gaps (registration.prepared stores them): no distance transform.
        """
        size = int(np.prod(grid.shape))
        if index.shape != (size,) or gap.shape != (size,):
            raise ValueError(
                f"a lookup grid of {tuple(grid.shape)} voxels needs {size} indices and gaps; "
                f"got {index.shape} and {gap.shape}"
            )
        lookup = cls.__new__(cls)
        lookup._set(samples, grid, index, gap)  # noqa: SLF001 - the class's own constructor
        return lookup

    @property
    def grid(self) -> VoxelGrid:
        """The grid's placement, voxel size and reach."""
        return VoxelGrid(self.origin, self.h, self.shape, self.reach)

    def _flat(self, points: Array) -> Array:
        """Flat voxel index (...) of points (..., 3); points outside the box fall on the
        border layer (no sample)."""
        cell = ((points - self.origin) * (1.0 / self.h)).astype(np.int32)
        # astype truncates towards zero: points just below the origin land on voxel 0, the
        # border, as do all the others outside.
        np.clip(cell, 0, self._last, out=cell)
        s0, s1, _ = self._strides
        return cell[..., 0] * s0 + cell[..., 1] * s1 + cell[..., 2]

    def distance(self, points: Array) -> Array:
        """Approximate distances (...) of points (..., 3) to the surface sample: the distance
        from their voxel to the nearest voxel holding a sample (inf where there is none).
        Within about one voxel diagonal of the truth; for scoring many poses at once."""
        return self.gap[self._flat(points)]

    def query(self, points: Array) -> tuple[Array, Array]:
        """Approximate nearest samples for points (..., 3).

        Returns:
            distances (...) to the returned samples (inf where there is none) and their
            indices (...) (-1 where there is none).
        """
        idx = self.index[self._flat(points)]
        d = np.linalg.norm(points - self.samples[np.maximum(idx, 0)], axis=-1)
        return np.where(idx >= 0, d, np.inf), idx
