"""A CT scanner simulated on a known surface (the phantom), so that a model built from the
scan carries the error a CT-derived model really has.

The object, in its model frame (which becomes the scan's LPS patient frame), is sampled on
the scanner's voxel grid with partial-volume averaging (each voxel holds the fraction of it
inside the object, from the exact signed distance to the surface and the voxel's extent
across it), blurred by the scanner's point-spread function (a Gaussian of `blur_mm` FWHM on
every axis; the slice's own thickness is in the voxel averaging) and given white noise of
`noise_hu`. Segmenting and meshing it (bone.py) then errs as a real CT does: the threshold's
bias through the blur, the staircase across thick slices, edges rounded.
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np
from scipy import ndimage

from models.ct.volume import Volume, VolumeError
from models.mesh import TriangleMesh

FWHM_PER_SIGMA = 2.0 * np.sqrt(2.0 * np.log(2.0))


@dataclass(frozen=True)
class CTSettings:
    """A head CT of the phantom. `voxel_mm` (i, j, k): 0.5 mm in-plane and 1.0 mm slices, a
    clinical head protocol's; `blur_mm`: FWHM of the point-spread function (a standard
    reconstruction kernel's 0.6-0.9 mm in-plane); `noise_hu`: voxel noise (20 HU); `iso_hu`:
    the bone threshold of the segmentation; `object_hu`, `background_hu`: the phantom's
    material (bone-equivalent plastic, about 1200 HU) and air; `margin_mm` of air around it."""

    voxel_mm: tuple[float, float, float] = (0.5, 0.5, 1.0)
    blur_mm: float = 0.7
    noise_hu: float = 20.0
    iso_hu: float = 300.0
    object_hu: float = 1200.0
    background_hu: float = -1000.0
    margin_mm: float = 5.0

    def __post_init__(self) -> None:
        voxel = np.asarray(self.voxel_mm, dtype=float)
        if voxel.shape != (3,) or not np.all((voxel >= 0.1) & (voxel <= 5.0)):
            raise VolumeError(f"ct.voxel_mm must be 3 sizes in [0.1, 5] mm, got {self.voxel_mm}")
        if not (0.0 <= self.blur_mm <= 5.0 and 0.0 <= self.noise_hu <= 500.0):
            raise VolumeError(
                f"ct.blur_mm in [0, 5] and ct.noise_hu in [0, 500], got {self.blur_mm}, "
                f"{self.noise_hu}"
            )
        if not self.background_hu < self.iso_hu < self.object_hu:
            raise VolumeError(
                f"ct.iso_hu {self.iso_hu} must lie between the background "
                f"{self.background_hu} and the object {self.object_hu} HU"
            )


def _signed_distance(points: np.ndarray, V: np.ndarray, F: np.ndarray, bound: float) -> tuple[
    np.ndarray, np.ndarray
]:  # fmt: skip
    """Signed distance (N,) [mm] (inside < 0) and unit normals (N, 3) of points within
    `bound` of the surface; beyond it, +-bound by the winding number's side and no normal."""
    S, _I, _C, N = igl.signed_distance(
        points, V, F, sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL,
        lower_bound=-bound, upper_bound=bound,
    )  # fmt: skip
    S, N = np.asarray(S, dtype=float), np.nan_to_num(np.asarray(N, dtype=float))
    far = ~np.isfinite(S)
    if far.any():
        inside = igl.fast_winding_number(V, F, np.ascontiguousarray(points[far])) > 0.5
        S[far] = np.where(inside, -bound, bound)
    return S, N


def _upsample(a: np.ndarray, m: int, axis: int) -> np.ndarray:
    """Linear interpolation of `a` onto m times finer samples along `axis` (the ends kept)."""
    if m == 1:
        return a
    n = a.shape[axis]
    i = np.arange(m * (n - 1) + 1)
    i0 = np.minimum(i // m, n - 2)
    t = ((i - i0 * m) / m).astype(a.dtype)
    shape = [1] * a.ndim
    shape[axis] = -1
    t = t.reshape(shape)
    return np.take(a, i0, axis=axis) * (1 - t) + np.take(a, i0 + 1, axis=axis) * t


def ct_scan(mesh: TriangleMesh, settings: CTSettings, rng: np.random.Generator) -> Volume:
    """The simulated CT of the closed surface `mesh` (model frame [m]) with `settings`; the
    volume's LPS frame is the model frame (in mm)."""
    V = np.asarray(mesh.vertices, dtype=float) * 1e3
    F = np.asarray(mesh.faces, dtype=np.int64)
    voxel = np.asarray(settings.voxel_mm, dtype=float)
    lo = V.min(axis=0) - settings.margin_mm
    shape = np.ceil((V.max(axis=0) + settings.margin_mm - lo) / voxel).astype(int) + 1
    # Coarse signed distances (on every m-th voxel, about 2 mm apart) find the voxels near
    # the surface; only those get their exact distance.
    m = np.maximum(np.round(2.0 / voxel), 1).astype(int)
    c_shape = np.ceil((shape - 1) / m).astype(int) + 1
    shape = m * (c_shape - 1) + 1
    axes = [lo[a] + m[a] * voxel[a] * np.arange(c_shape[a]) for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    band = 0.5 * float(voxel.sum()) + 1e-3
    reach = band + float(np.linalg.norm(m * voxel))  # + what the interpolation may miss
    s_coarse, _ = _signed_distance(grid, V, F, reach + 1.0)
    s = s_coarse.reshape(c_shape).astype(np.float32)
    for axis in range(3):
        s = _upsample(s, int(m[axis]), axis)
    fraction = (s < 0.0).astype(np.float32).ravel()
    near = np.flatnonzero(np.abs(s.ravel()) < reach)
    centres = lo + np.stack(np.unravel_index(near, tuple(shape)), axis=1) * voxel
    s_near, n_near = _signed_distance(centres, V, F, reach + 1.0)
    # The fraction of a voxel box inside a locally flat surface at signed distance s from
    # its centre: a ramp over the box's extent along the normal.
    width = 0.5 * np.abs(n_near) @ voxel
    width = np.where(width > 1e-6, width, 0.5 * float(voxel.mean()))  # no normal: the mean
    fraction[near] = np.clip(0.5 - s_near / (2.0 * np.maximum(width, 1e-6)), 0.0, 1.0)
    hu = settings.background_hu + fraction.reshape(shape) * (
        settings.object_hu - settings.background_hu
    )
    if settings.blur_mm > 0.0:
        hu = ndimage.gaussian_filter(hu, sigma=settings.blur_mm / FWHM_PER_SIGMA / voxel)
    if settings.noise_hu > 0.0:
        hu = hu + rng.normal(0.0, settings.noise_hu, hu.shape).astype(np.float32)
    affine = np.eye(4)
    affine[:3, :3] = np.diag(voxel)
    affine[:3, 3] = lo
    return Volume(hu.astype(np.float32), affine, "CT", "LPS", "simulated CT")
