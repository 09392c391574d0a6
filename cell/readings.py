"""What the controller reads from its sensors, as plain values."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class LaserReading:
    """One laser line: `distances` (n_rays,) [m], NaN where there was no return, and the
    measured (encoder) joints `q_measured` (6,) [rad] at the same instant, with the
    table readout `table_position_m`, the simulated time `time_s`."""

    distances: np.ndarray
    q_measured: np.ndarray
    table_position_m: float
    time_s: float

    @property
    def valid(self) -> np.ndarray:
        """(n_rays,) bool: rays with a return."""
        return np.isfinite(self.distances)
