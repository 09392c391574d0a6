"""The laser's data sheet as a job's configuration gives it (`cell.laser`): a line profiler
or a point laser, and its measuring range. The real cell is built from it with its noise;
the planner is told it without."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, field_validator

from cell.layout import LaserConfig

#: The measuring range [m] of each kind of laser when `cell.laser.range_m` is not given: a
#: line profiler's (0.05-0.6 m), and an analog triangulation sensor's such as Micro-Epsilon's
#: optoNCDT ILD1420-500 (its data sheet: 500 mm from 100 mm, sampling up to 4 kHz).
LASER_RANGES_M: dict[str, tuple[float, float]] = {"line": (0.05, 0.6), "point": (0.1, 0.6)}


class LaserSection(BaseModel):
    """The laser on the tool changer, as its data sheet gives it. `kind` "line": a laser
    line profiler, 256 rays in a 0.6 rad fan across the TCP's x-z plane; "point": the seed
    paper's analog distance sensor, one ray along the TCP's z, its reading on a controller
    input (a point laser's pass is a raster of lines `localization.scan.raster`). `range_m`
    (min, max) [m]: where it returns a reading (default LASER_RANGES_M for its kind)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal["line", "point"] = "line"
    range_m: tuple[float, float] | None = None

    @field_validator("range_m")
    @classmethod
    def _range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not 0.0 <= v[0] < v[1] <= 5.0:
            raise ValueError(f"range_m must be (min, max) with 0 <= min < max <= 5 m, got {v}")
        return v

    def data_sheet(self, sigma_m: float = 0.0) -> LaserConfig:
        """The laser as the cell has it (cell.layout.LaserConfig), with the range noise
        `sigma_m` [m] (the real cell's; the planner's data sheet has none): a line
        profiler's fan, or a point laser's single ray along the TCP's z."""
        lo, hi = self.range_m or LASER_RANGES_M[self.kind]
        if self.kind == "point":
            return LaserConfig(1, 0.0, lo, hi, sigma_m)
        return LaserConfig(range_min_m=lo, range_max_m=hi, sigma_m=sigma_m)


def single_ray(directions_tcp: np.ndarray) -> bool:
    """Whether a laser of these ray directions (N, 3) (a controller's data sheet) is a point
    laser: one ray, where a line profiler's fan has many."""
    return len(np.asarray(directions_tcp).reshape(-1, 3)) == 1
