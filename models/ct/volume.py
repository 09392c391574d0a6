"""A volume and its patient frame: the one place where image conventions meet.

`Volume.data` is indexed [i, j, k] (column, row, slice) and `affine_lps` maps a voxel index
(i, j, k, 1) to patient coordinates in DICOM's LPS convention (x to the patient's left, y to
the posterior, z to the head) in millimetres. NIfTI's RAS (x right, y anterior) is LPS with
x and y negated: `RAS_FROM_LPS` does it, here only. A model built from a volume lives in the
volume's LPS frame in metres (`lps_mm_to_model`), and so does a plan made on it: a mesh and
a plan of the same volume always agree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.model_errors import ModelError

#: RAS = RAS_FROM_LPS @ LPS (and back: it is its own inverse).
RAS_FROM_LPS = np.diag([-1.0, -1.0, 1.0, 1.0])
FRAMES = ("LPS", "RAS")
#: Steps that differ from their median by less than this fraction are even.
STEP_TOLERANCE = 0.01


class VolumeError(ModelError, ValueError):
    """A volume, a segmentation of it or a plan on it that cannot be used: the message names
    the file and the problem."""


@dataclass(frozen=True)
class SkippedFiles:
    """Files of a series folder left out of its volume: the folder, how many files it holds
    and each file left out with why, as (name, reason)."""

    folder: str
    total: int
    files: tuple[tuple[str, str], ...]

    #: How many of the files the one-line form names (it counts them all).
    SHOWN = 10

    def __str__(self) -> str:
        shown = ", ".join(f"{name} ({why})" for name, why in self.files[: self.SHOWN])
        more = len(self.files) - self.SHOWN
        rest = f", and {more} more" if more > 0 else ""
        return f"{len(self.files)} of {self.total} files in {self.folder} skipped: {shown}{rest}"


@dataclass(frozen=True)
class Resampling:
    """How a series was put onto a regular grid: its slice steps along the normal, smallest
    and largest [mm]; the tilt of its slices' stacking direction from their normal [deg]
    (the gantry tilt); the regular grid's voxel size (i, j, k) [mm] and shape; the slices
    read."""

    step_min_mm: float
    step_max_mm: float
    tilt_deg: float
    voxel_mm: tuple[float, float, float]
    shape: tuple[int, int, int]
    slices: int

    def __str__(self) -> str:
        steps = (
            f"slice steps {self.step_min_mm:.2f}-{self.step_max_mm:.2f} mm"
            if self.step_max_mm - self.step_min_mm > STEP_TOLERANCE * self.step_min_mm
            else f"even slice steps {self.step_min_mm:.2f} mm"
        )
        grid = " x ".join(f"{v:.2f}" for v in self.voxel_mm)
        return (
            f"resampled: {steps}, tilt {self.tilt_deg:.1f} deg -> regular {grid} mm grid "
            f"({self.slices} slices -> {self.shape[2]})"
        )


@dataclass(frozen=True, eq=False)
class Volume:
    """An image volume: `data` (I, J, K) float values (Hounsfield units for CT), `affine_lps`
    (4, 4) voxel index -> LPS [mm], `modality` ("CT", "MR", ... or None if the file does not
    say), `native_frame` the frame its file and its plans use ("LPS" for DICOM and NRRD in
    LPS, "RAS" for NIfTI and NRRD in RAS), `source` the file or folder it came from,
    `resampled` how its slices were put onto this regular grid (models.ct.regular; None: the
    file's own grid), `skipped` the files of its series folder that were left out (None:
    none)."""

    data: np.ndarray
    affine_lps: np.ndarray
    modality: str | None
    native_frame: str
    source: str
    resampled: Resampling | None = None
    skipped: SkippedFiles | None = None

    def __post_init__(self) -> None:
        data = np.asarray(self.data)
        affine = np.asarray(self.affine_lps, dtype=float)
        if data.ndim != 3 or min(data.shape) < 2:
            raise VolumeError(
                f"{self.source}: a volume needs 3 axes of 2+ voxels, got {data.shape}"
            )
        if not np.isfinite(data).all():
            bad = int(np.size(data) - np.isfinite(data).sum())
            raise VolumeError(f"{self.source}: {bad} voxel values are NaN or infinite")
        if affine.shape != (4, 4) or not np.isfinite(affine).all():
            raise VolumeError(f"{self.source}: the voxel-to-patient affine is not a finite 4x4")
        if abs(np.linalg.det(affine[:3, :3])) < 1e-12:
            raise VolumeError(f"{self.source}: the voxel axes are degenerate (zero spacing)")
        if self.native_frame not in FRAMES:
            raise VolumeError(f"{self.source}: frame {self.native_frame!r}, valid: {FRAMES}")

    @property
    def spacing_mm(self) -> np.ndarray:
        """(3,) voxel size along i, j, k [mm]."""
        return np.linalg.norm(self.affine_lps[:3, :3], axis=0)

    def index_to_lps(self, ijk: np.ndarray) -> np.ndarray:
        """Voxel indices (N, 3) (fractional allowed) -> LPS [mm]."""
        ijk = np.asarray(ijk, dtype=float)
        return ijk @ self.affine_lps[:3, :3].T + self.affine_lps[:3, 3]

    def lps_to_index(self, p_lps: np.ndarray) -> np.ndarray:
        """LPS [mm] (N, 3) -> fractional voxel indices (N, 3)."""
        p = np.asarray(p_lps, dtype=float) - self.affine_lps[:3, 3]
        return np.linalg.solve(self.affine_lps[:3, :3], p.T).T

    def native_to_lps(self, p: np.ndarray, frame: str) -> np.ndarray:
        """Points (N, 3) [mm] in `frame` (LPS or RAS) -> LPS [mm]."""
        p = np.asarray(p, dtype=float)
        if frame == "LPS":
            return p
        if frame == "RAS":
            return p @ RAS_FROM_LPS[:3, :3].T
        raise VolumeError(f"{self.source}: frame {frame!r}, valid: {FRAMES}")

    def contains(self, p_lps: np.ndarray) -> np.ndarray:
        """(N,) whether LPS points [mm] lie within the volume's voxel grid."""
        ijk = self.lps_to_index(np.atleast_2d(p_lps))
        upper = np.array(self.data.shape) - 1
        return np.all((ijk >= -0.5) & (ijk <= upper + 0.5), axis=1)


def lps_mm_to_model(p_lps_mm: np.ndarray) -> np.ndarray:
    """Points in a volume's LPS frame [mm] -> the model frame of its meshes [m]."""
    return np.asarray(p_lps_mm, dtype=float) * 1e-3
