"""The points a match works on: drawn from the data, with the scales of the match.

A `MatchWork` holds the data points drawn for the search and the refinement, which of them
lie on a surface, the floor of the residual scale, the robust kernel and the reach beyond
which a point is an outlier of any refined pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration.kernels import Kernel, Tukey
from registration.match_request import MatchRequest, resolution_floor
from registration.rigid import Array
from registration.search import subsample
from registration.shapes.base import Closest, Shape
from registration.starts import surface_points


@dataclass(frozen=True, eq=False)
class MatchWork:
    """What a match works on: the model, the data points drawn (`used` (n,), indices into
    the data in the order of a coarse grid) and those points `work` (n, 3), which of them
    lie on a surface (`strict_surface` (n,)) and the fraction that lie on one loosely;
    the points the search and the refinement fit (`fit` (m, 3)) and its subsamples `mid`
    and `ranked`; the floor of the residual scale and the robust kernel; and the `reach`
    beyond which a point is an outlier of any refined pose [length units]."""

    shape: Shape
    used: Array
    work: Array
    strict_surface: Array
    surface: float
    fit: Array
    mid: Array
    ranked: Array
    floor: float
    kernel: Kernel
    reach: float

    def near(self, p: Array) -> Closest:
        """The model's closest points to `p` (N, 3) from its surface sample, within reach."""
        return self.shape.near(p, self.reach)

    def exact(self, p: Array) -> Closest:
        """The model's exact closest points to `p` (N, 3), within reach."""
        return self.shape.closest_within(p, self.reach)


def draw_work(request: MatchRequest, rng: np.random.Generator) -> MatchWork:
    """The points the match works on, drawn from the data with `rng`, and its scales."""
    data, shape, settings = request.data, request.shape, request.settings
    extent = shape.extent
    # Random (seeded) subsamples keep the data's outlier fraction; a farthest-point sample
    # would pick the spurious points first.
    used = subsample(data, settings.refine_points, rng)
    # In the order of a coarse grid: neighbours in space are neighbours in memory, which
    # speeds up every closest-point query by about a quarter.
    cell = np.floor((data[used] - data[used].min(axis=0)) / (0.05 * extent)).astype(np.int64)
    used = used[np.lexsort(cell.T[::-1])]
    work = data[used]
    # The search and the refinement work on the points that lie on a surface; the quality
    # (inlier fraction, residuals, covariance) is computed on all of them.
    surface_of = surface_points(work, data)
    on_surface = surface_of.loose
    fit = work[on_surface] if on_surface.sum() >= 10 else work
    mid = fit[subsample(fit, settings.mid_points, rng)]
    ranked = fit[subsample(fit, settings.rank_points, rng)]
    floor = request.noise if request.noise is not None else resolution_floor(data, extent)
    return MatchWork(
        shape=shape,
        used=used,
        work=work,
        strict_surface=surface_of.strict,
        surface=float(on_surface.mean()),
        fit=fit,
        mid=mid,
        ranked=ranked,
        floor=floor,
        kernel=request.kernel or Tukey(min_scale=floor),
        # Points farther than this from the model are outliers of any refined pose: they
        # get a residual of `reach` instead of an exact (slow) answer.
        reach=settings.reach * extent,
    )
