"""Slices that do not form a regular grid, put onto one: a series whose slice steps vary (a
head CT with 1 mm slices near the skull base and 7 mm above it), or whose slices were taken
with the gantry tilted (their positions advance along the table, not along the slices'
normal), or any series asked for at a given voxel size.

The slices are parallel planes (one orientation), each a regular pixel grid; slice k lies at
`w_k` along the planes' normal and its origin is shifted across the plane by `(du_k, dv_k)`.
The regular grid has the slices' row and column directions and their normal as axes (an
orthonormal frame in the patient space), the pixel spacing in-plane and the smallest step
along the normal (or the voxel size asked for), and covers every slice. Its values are the
trilinear interpolation of the slices' cells (scipy.ndimage.map_coordinates, order 1): at
height w between slices k and k+1 the fractional slice index and the in-plane shift are
interpolated linearly, so that a sheared, unevenly spaced cell is interpolated as the
scanner's own lattice. Points outside every slice get the series' lowest value (air).

A step larger than `max_gap_mm` (missing slices) is refused, naming the gap and where.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from models.ct.volume import STEP_TOLERANCE, Resampling, Volume, VolumeError

#: The largest step between neighbouring slices that is interpolated over [mm]: wider is a
#: gap of missing slices (clinical CT slices are at most 5-7.5 mm apart).
MAX_GAP_MM = 10.0
#: Slice origins that drift across the plane by less than this fraction of a pixel over the
#: whole series are no tilt.
DRIFT_TOLERANCE = 0.05
#: Two slices closer than this along the normal are the same slice twice [mm].
SAME_SLICE_MM = 1e-3


@dataclass(frozen=True, eq=False)
class SliceStack:
    """Parallel slices sorted along their normal: `values` (I, J, K) (column i, row j, slice
    k), `origins` (K, 3) [mm] each slice's pixel (0, 0) in the patient frame (LPS), `row`
    and `col` (3,) unit directions of i and j, `pixel_mm` (2,) the spacing along i and j
    [mm], `names` (K,) where each slice came from (for messages)."""

    values: np.ndarray
    origins: np.ndarray
    row: np.ndarray
    col: np.ndarray
    pixel_mm: np.ndarray
    names: tuple[str, ...]

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal of the slices (row x col)."""
        n = np.cross(self.row, self.col)
        return n / np.linalg.norm(n)

    def heights(self) -> np.ndarray:
        """(K,) each slice's position along the normal from the first [mm]."""
        return (self.origins - self.origins[0]) @ self.normal

    def shifts(self) -> np.ndarray:
        """(K, 2) each slice origin's shift across the plane from the first (along i, j)
        [mm]."""
        d = self.origins - self.origins[0]
        return np.stack([d @ self.row, d @ self.col], axis=1)


def voxel_size(value: float | Sequence[float] | str | None) -> tuple[float, float, float] | None:
    """A voxel size from one size (isotropic), three, or "AxBxC" [mm]; None stays None.
    Raises VolumeError for anything else or sizes outside [0.05, 20] mm."""
    if value is None:
        return None
    try:
        if isinstance(value, str):
            sizes = [float(v) for v in value.lower().split("x")]
        elif isinstance(value, int | float):
            sizes = [float(value)]
        else:
            sizes = [float(v) for v in value]
    except (TypeError, ValueError):
        sizes = []
    if len(sizes) == 1:
        sizes *= 3
    if len(sizes) != 3 or not all(np.isfinite(s) and 0.05 <= s <= 20.0 for s in sizes):
        raise VolumeError(
            f"voxel size {value!r}: one size or AxBxC, each in [0.05, 20] mm (e.g. 0.5 or "
            "0.5x0.5x1)"
        )
    return (sizes[0], sizes[1], sizes[2])


def check_steps(stack: SliceStack, where: str, max_gap_mm: float = MAX_GAP_MM) -> np.ndarray:
    """The steps (K-1,) between neighbouring slices along the normal [mm]; raises
    VolumeError for a slice given twice or a gap wider than `max_gap_mm`, naming it."""
    if not (np.isfinite(max_gap_mm) and max_gap_mm > 0.0):
        raise VolumeError(f"max gap {max_gap_mm!r} mm: must be > 0")
    steps = np.diff(stack.heights())
    names = stack.names
    same = np.flatnonzero(steps < SAME_SLICE_MM)
    if same.size:
        k = int(same[0])
        raise VolumeError(
            f"{where}: two slices at the same position ({names[k]}, {names[k + 1]}): one "
            "series at a time"
        )
    wide = np.flatnonzero(steps > max_gap_mm)
    if wide.size:
        k = int(wide[np.argmax(steps[wide])])
        w = stack.heights()
        raise VolumeError(
            f"{where}: slice gap of {steps[k]:.1f} mm between {names[k]} and {names[k + 1]} "
            f"({w[k]:.1f} to {w[k + 1]:.1f} mm along the slices' normal from the first; "
            f"{wide.size} gap(s) wider than {max_gap_mm:g} mm): missing slices (a larger "
            "gap is allowed with --max-gap-mm / model.ct.max_gap_mm)"
        )
    return steps


def is_regular(stack: SliceStack, steps: np.ndarray) -> bool:
    """Whether the slices already form a regular grid: even steps and no drift across the
    plane."""
    median = float(np.median(steps))
    even = bool(np.all(np.abs(steps - median) <= STEP_TOLERANCE * median))
    drift = np.abs(stack.shifts()) / stack.pixel_mm
    return even and bool(np.all(drift <= DRIFT_TOLERANCE))


def tilt_deg(stack: SliceStack) -> float:
    """The angle between the slices' stacking direction (first to last origin) and their
    normal [deg]."""
    d = stack.origins[-1] - stack.origins[0]
    along = float(d @ stack.normal)
    across = float(np.linalg.norm(d - along * stack.normal))
    return float(np.degrees(np.arctan2(across, abs(along))))


def resample(
    stack: SliceStack,
    steps: np.ndarray,
    voxel_mm: tuple[float, float, float] | None,
    modality: str | None,
    where: str,
    frame: str = "LPS",
) -> Volume:
    """The slices on a regular grid (see the module's docstring) as a volume that records
    the resampling (`frame`: the native frame of its file and plans); `voxel_mm` (i, j, k)
    [mm], None: the pixel spacing and the smallest step."""
    heights, shifts = stack.heights(), stack.shifts()
    n_i, n_j, _k = stack.values.shape
    size = np.array(
        voxel_mm if voxel_mm is not None else (*stack.pixel_mm, float(steps.min())), dtype=float
    )
    lower = shifts.min(axis=0)
    upper = shifts.max(axis=0) + (np.array([n_i, n_j]) - 1) * stack.pixel_mm
    extent = np.array([*(upper - lower), heights[-1]])
    shape = (np.floor(extent / size + 1e-6).astype(int) + 1).tolist()
    if int(np.prod(shape)) > 2_000_000_000 // 4:
        raise VolumeError(
            f"{where}: a {' x '.join(map(str, shape))} grid at {size.tolist()} mm is too large "
            "(2 GB); give a coarser voxel size"
        )
    u = lower[0] + size[0] * np.arange(shape[0])
    v = lower[1] + size[1] * np.arange(shape[1])
    values = np.asarray(stack.values, dtype=np.float32)
    fill = float(values.min())
    out = np.empty(shape, dtype=np.float32)
    slice_index = np.arange(len(heights), dtype=float)
    for m in range(shape[2]):
        w = m * size[2]
        k = np.interp(w, heights, slice_index)
        du, dv = np.interp(w, heights, shifts[:, 0]), np.interp(w, heights, shifts[:, 1])
        i = (u - du) / stack.pixel_mm[0]
        j = (v - dv) / stack.pixel_mm[1]
        ii, jj = np.meshgrid(i, j, indexing="ij")
        coords = np.stack([ii, jj, np.full_like(ii, k)])
        out[:, :, m] = ndimage.map_coordinates(values, coords, order=1, mode="constant", cval=fill)
    affine = np.eye(4)
    affine[:3, 0] = stack.row * size[0]
    affine[:3, 1] = stack.col * size[1]
    affine[:3, 2] = stack.normal * size[2]
    affine[:3, 3] = stack.origins[0] + lower[0] * stack.row + lower[1] * stack.col
    record = Resampling(
        float(steps.min()),
        float(steps.max()),
        tilt_deg(stack),
        (float(size[0]), float(size[1]), float(size[2])),
        (int(shape[0]), int(shape[1]), int(shape[2])),
        len(heights),
    )
    return Volume(out, affine, modality, frame, where, record)


def regularize(
    volume: Volume, voxel_mm: tuple[float, float, float] | None, max_gap_mm: float = MAX_GAP_MM
) -> Volume:
    """`volume` (a NIfTI's or an NRRD's, whose grid is given by its affine) on a regular grid
    if its slice axis is sheared off the slices' normal (a gantry tilt the file kept) or a
    `voxel_mm` is asked for; else itself. A grid whose in-plane axes are not perpendicular
    is kept as the file gives it (its affine maps it exactly)."""
    A = volume.affine_lps[:3, :3]
    a_i, a_j, a_k = (A[:, c] for c in range(3))
    s_i, s_j = float(np.linalg.norm(a_i)), float(np.linalg.norm(a_j))
    if abs(float(a_i @ a_j)) > 1e-6 * s_i * s_j:
        return volume
    row, col = a_i / s_i, a_j / s_j
    data = np.asarray(volume.data)
    n = np.cross(row, col)
    origin = volume.affine_lps[:3, 3]
    if float(a_k @ n) < 0.0:  # slices stacked against the normal: take them the other way
        data, origin, a_k = data[:, :, ::-1], origin + a_k * (data.shape[2] - 1), -a_k
    count = data.shape[2]
    stack = SliceStack(
        data,
        origin + np.arange(count)[:, None] * a_k,
        row,
        col,
        np.array([s_i, s_j]),
        tuple(f"slice {k}" for k in range(count)),
    )
    steps = check_steps(stack, volume.source, max_gap_mm)
    if voxel_mm is None and is_regular(stack, steps):
        return volume
    return resample(stack, steps, voxel_mm, volume.modality, volume.source, volume.native_frame)
