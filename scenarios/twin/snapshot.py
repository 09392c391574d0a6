"""What the served controller knows at one instant of its time (`Snapshot`): published by
its worker every control period, read by RWS and streamed by EGM."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Snapshot:
    """What the controller knows at its time `time_s` [s]: the encoders q (6,) [rad], the
    joints it commands q_ref (6,) [rad], the flange T_base_flange (4, 4) [m] (nominal
    kinematics), the table's readout [m], the tool in hand, the TCP check's beam (broken
    or not) and the IR sensor's distance [m] while it is in hand (None: nothing in range, or
    not in hand)."""

    time_s: float
    q: np.ndarray
    q_ref: np.ndarray
    T_base_flange: np.ndarray
    table_m: float
    tool: str | None
    beam: bool = False
    ir_m: float | None = None
