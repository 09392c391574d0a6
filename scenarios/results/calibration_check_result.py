"""A kept calibration's quick check as results.json keeps it (scenarios.offline.
calibration_check makes it): how far the reference spheres have moved since the calibration,
with its uncertainty, against the tolerance it is held to."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DriftCheck:
    """The quick check: each sphere's centre now less where the calibration found it
    (`shifts_m` (S, 3), base frame [m]), the standard uncertainty of one shift per axis
    (`sigma_m` [m]), the largest shift's length (`drift_m`) and its 95 % upper bound
    (`bound_m`), the tolerance it is held to, whether it passed (else the cell was
    calibrated anew), and what it took: views, points, wall seconds."""

    shifts_m: np.ndarray
    sigma_m: float
    drift_m: float
    bound_m: float
    tolerance_m: float
    passed: bool
    views: int
    points: int
    seconds: float
