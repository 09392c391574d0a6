"""A shift on one cell as its table keeps it (scenarios.jobs.shift makes it): one row per job,
and the shift's figures over its jobs."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal

import numpy as np

#: What a shift does with the calibration between jobs: `check` the last one on the spheres
#: and keep it where the cell has not moved, else calibrate anew; calibrate `once` (the first
#: job) and keep that; calibrate `every` job.
Policy = Literal["check", "once", "every"]
POLICIES: tuple[Policy, ...] = ("check", "once", "every")


@dataclass(frozen=True)
class ShiftJob:
    """One job of a shift: its number, when it started on the shift's clock [h], the arm's
    warmth then (0 cold, 1 fully warm; truth), the zero shift of joint 2 that makes [rad]
    and the links' growth (dL/L) with the ambient's change (truth); how it ended (status,
    reason); what it did with the calibration (`calibrated`: made anew without one, `kept`:
    given and kept, `recalibrated`: given, checked and made anew, `expired`: the last one
    older than `calibration.max_age_h` on the shift's clock, so none given and made anew,
    `failed`: the job stopped before it was settled) and the check's drift, its 95 % bound
    and the tolerance the bound was held to [m] (None: not checked); its targets' RMS and
    largest error [m] as its own run touched them and as its exported program did (truth;
    None where none ran); whether it met its goals; its cell time and wall time [s]; its run
    folder (relative to the shift's)."""

    job: int
    start_h: float
    warmth: float
    warmup_j2_rad: float
    thermal_strain: float
    status: str
    reason: str
    calibration: str
    check_drift_m: float | None
    check_bound_m: float | None
    check_tolerance_m: float | None
    target_rms_m: float | None
    target_max_m: float | None
    exported_rms_m: float | None
    exported_max_m: float | None
    goals_met: bool | None
    cell_time_s: float | None
    wall_s: float
    folder: str

    @classmethod
    def columns(cls) -> tuple[str, ...]:
        """The table's columns, in order."""
        return tuple(f.name for f in fields(cls))


@dataclass(frozen=True)
class ShiftResult:
    """A shift: its job, its arm and its cell's seed, its policy, the jobs asked for over how
    many hours, and each job run."""

    job: str
    robot: str
    seed: int
    policy: Policy
    jobs_asked: int
    hours: float
    jobs: tuple[ShiftJob, ...]

    def column(self, name: str, scale: float = 1.0) -> np.ndarray:
        """The jobs' figure `name` (a ShiftJob field), times `scale` (1e3: [m] to [mm]), NaN
        where a job has none."""
        values = [getattr(job, name) for job in self.jobs]
        return np.array([np.nan if v is None else v * scale for v in values], dtype=float)

    @property
    def mean_cell_time_s(self) -> float | None:
        """The mean cell time per job [s] (None: no job reported one)."""
        times = [j.cell_time_s for j in self.jobs if j.cell_time_s is not None]
        return float(np.mean(times)) if times else None

    @property
    def missed_while_complete(self) -> int:
        """Jobs that ended `complete` with a goal missed (a check that should have caught it)."""
        return sum(1 for j in self.jobs if j.status == "complete" and j.goals_met is False)

    def count(self, status: str) -> int:
        """How many jobs ended with `status`."""
        return sum(1 for j in self.jobs if j.status == status)
