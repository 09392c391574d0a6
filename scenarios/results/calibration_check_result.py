"""A kept calibration's quick check as results.json keeps it (scenarios.offline.
calibration_check makes it): how far the reference spheres have moved since the calibration,
with its uncertainty, against the tolerance it is held to."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DriftCheck:
    """The quick check: each measured sphere's centre now less where the calibration found
    it (`shifts_m` (S, 3), base frame [m]; a sphere seen in fewer than three views is not
    measured), the standard uncertainty of one shift per axis (`sigma_m` [m]), the largest
    shift's length (`drift_m`) and its 95 % upper bound (`bound_m`), the tolerance it is held
    to, whether it passed (else the cell was calibrated anew), and what it took: views,
    points, wall seconds. With fewer than two spheres measured the check has no figure
    (None) and does not pass."""

    shifts_m: np.ndarray
    sigma_m: float | None
    drift_m: float | None
    bound_m: float | None
    tolerance_m: float
    passed: bool
    views: int
    points: int
    seconds: float

    @property
    def kept_error_m(self) -> float | None:
        """The error a calibration kept by this check carries at the spheres, as a standard
        error [m]: the RMS of the spheres' shifts with each shift's own uncertainty (three
        axes of `sigma_m`); None where the check did not pass (the calibration was made
        anew) or has no figure."""
        if not self.passed or self.sigma_m is None or len(self.shifts_m) == 0:
            return None
        shift_sq = float(np.mean(np.sum(self.shifts_m**2, axis=1)))
        return float(np.sqrt(shift_sq + 3.0 * self.sigma_m**2))
