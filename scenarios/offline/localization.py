"""Locating the object on the table from its scan: the object points thinned and
subsampled, matched to the virtual model, the pose returned in the nominal table frame.
Shared by the skull and assembly jobs and their benchmarks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration import (
    Acceptance,
    MatchResult,
    MeshModel,
    invert,
    match,
    transform_points,
)
from registration.match_request import Mode
from registration.quality import ScanPasses
from registration.search import SearchSettings


@dataclass(frozen=True, eq=False)
class Localization:
    """The matched object pose: T_table_object (4, 4) in the nominal table frame, the match,
    the points used (M, 3) and the number of cropped object points."""

    T_table_object: np.ndarray
    result: MatchResult
    points_used: np.ndarray
    object_points: int


def voxel_thin(points: np.ndarray, voxel_m: float) -> np.ndarray:
    """Indices (K,) of the first point of `points` (N, 3) in each occupied cube of side
    `voxel_m` [m] (every index if voxel_m is 0)."""
    if voxel_m <= 0.0:
        return np.arange(len(points))
    keys = np.floor(points / voxel_m).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def scan_passes(pass_labels: np.ndarray, pass_sigma_m: float | None) -> ScanPasses | None:
    """The scan's passes as the match takes them: the pass of each point (N,) and the arm's
    accuracy `pass_sigma_m` [m] (a pass's rigid offset, per axis); None if that is not
    given."""
    return None if pass_sigma_m is None else ScanPasses(pass_labels, pass_sigma_m)


def localize(
    points_table: np.ndarray,
    shape: MeshModel,
    max_points: int,
    acceptance: Acceptance,
    seed: int,
    voxel_m: float = 0.0,
    mode: Mode = "auto",
    T_table_object_prior: np.ndarray | None = None,
    passes: ScanPasses | None = None,
    targets_model: np.ndarray | None = None,
) -> Localization:
    """Match the object points (N, 3) in the table frame to the virtual model: thinned to
    one point per `voxel_m` cube, then a seeded subsample of at most `max_points`, all of
    which the pose is refined on. Mode "auto" (or "local", "global") searches without prior;
    "refine" starts from `T_table_object_prior` (4, 4). With the scan's `passes` (the pass
    of each of the N points, and the arm's accuracy: a pass's rigid offset per axis [m];
    see `scan_passes`), the predicted TRE includes it. With the operation's targets (K, 3)
    in the model frame, the verdict is per target: accepted only if every target is
    located."""
    rng = np.random.default_rng(seed)
    index = voxel_thin(points_table, voxel_m)
    if len(index) > max_points:
        index = index[np.sort(rng.choice(len(index), max_points, replace=False))]
    used = points_table[index]
    used_passes = None
    if passes is not None:
        used_passes = ScanPasses(np.asarray(passes.labels)[index], passes.sigma_offset)
    T_init = (
        None if T_table_object_prior is None or mode != "refine" else invert(T_table_object_prior)
    )
    result = match(
        used,
        shape,
        mode=mode,
        T_init=T_init,
        targets=targets_model,
        seed=seed,
        acceptance=acceptance,
        settings=SearchSettings(refine_points=max_points),
        passes=used_passes,
    )
    return Localization(invert(result.T_model_data), result, used, len(points_table))


#: Scan points farther than this from the matched model (or 8 times the match's RMS if
#: larger) are not the object's surface [m]: a laser's spurious returns, or something on the
#: table that is not the object.
STRAY_M = 2.0e-3
#: So many such points (at least, and at least this fraction of the scan) make a report (a
#: few are a scan's stray returns at edges).
STRAY_POINTS = 10
STRAY_FRACTION = 5.0e-4


def stray_returns(
    points_table: np.ndarray, shape: MeshModel, T_table_object: np.ndarray, rms_m: float
) -> int:
    """How many of the object's scan points (N, 3, table frame) lie off the matched model
    (`shape` at T_table_object, 4 x 4) by more than STRAY_M or 8 RMS; 0 if fewer than
    STRAY_POINTS or STRAY_FRACTION of them do. The match's robust estimator leaves such
    points out; this counts them, so that a run tells what its laser returned wrongly."""
    p_model = transform_points(invert(T_table_object), points_table)
    far = int(np.sum(shape.closest(p_model).distances > max(STRAY_M, 8.0 * rms_m)))
    return far if far >= max(STRAY_POINTS, STRAY_FRACTION * len(points_table)) else 0
