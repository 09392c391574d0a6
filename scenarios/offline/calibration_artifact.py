"""The calibration's artifact: reference spheres on square posts standing on the table
(`SphereArtifact`), the cell's own (`DEFAULT_ARTIFACT`), and the error a calibration that
cannot be trusted raises (scenarios.offline.calibration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import FixedPrimitive
from registration.rigid import make_T
from scenarios.scenario_errors import ScenarioError


class CalibrationError(ScenarioError, ValueError):
    """The calibration cannot be trusted: too few views or points, or a poor fit."""


@dataclass(frozen=True)
class SphereArtifact:
    """Reference spheres on square posts standing on the table.

    `centres_table` (S, 3) the spheres' nominal centres in the table frame [m] (where the
    artifact is designed to stand; the calibration estimates the real ones), `radius_m` their
    radius [m] (a certified figure), `post_half_m` the posts' half width [m].
    """

    centres_table: np.ndarray
    radius_m: float = 0.025
    post_half_m: float = 0.006

    def __post_init__(self) -> None:
        c = np.asarray(self.centres_table, dtype=float)
        if c.ndim != 2 or c.shape[1] != 3 or len(c) < 1 or not np.all(np.isfinite(c)):
            raise CalibrationError(
                f"sphere centres must be a finite (S>=1, 3) array, got shape {c.shape}"
            )
        if not (np.isfinite(self.radius_m) and self.radius_m > 0.0):
            raise CalibrationError(f"sphere radius must be > 0 m, got {self.radius_m!r}")
        if np.any(c[:, 2] < self.radius_m + 0.01):
            raise CalibrationError(
                f"spheres must stand at least 10 mm above the table top, got centre heights "
                f"{c[:, 2].tolist()} m for a radius of {self.radius_m} m"
            )
        object.__setattr__(self, "centres_table", c)

    def fixtures(self, centres_table: np.ndarray | None = None) -> tuple[FixedPrimitive, ...]:
        """The spheres and their posts as cell fixtures, the spheres at `centres_table`
        (S, 3) [m] (default: the nominal centres)."""
        c = self.centres_table if centres_table is None else np.asarray(centres_table, float)
        out = []
        for i, centre in enumerate(c):
            out.append(
                FixedPrimitive(
                    f"calibration_sphere{i + 1}",
                    "sphere",
                    (self.radius_m,),
                    make_T(np.eye(3), centre),
                    rgba=(0.9, 0.9, 0.9, 1.0),
                )
            )
            top = centre[2] - 0.9 * self.radius_m  # the post ends inside the sphere
            out.append(
                FixedPrimitive(
                    f"calibration_post{i + 1}",
                    "box",
                    (self.post_half_m, self.post_half_m, top / 2),
                    make_T(np.eye(3), np.array([centre[0], centre[1], top / 2])),
                    rgba=(0.3, 0.3, 0.3, 1.0),
                )
            )
        return tuple(out)


#: The cell's artifact: three spheres along x at the +y end of the table, at three heights.
#: With the table at -0.25 m they stand in front of the arm, where the skull job works.
DEFAULT_ARTIFACT = SphereArtifact(
    np.array([[-0.12, 0.25, 0.09], [0.0, 0.26, 0.15], [0.12, 0.25, 0.11]]), radius_m=0.025
)
