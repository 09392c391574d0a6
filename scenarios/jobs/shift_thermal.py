"""The arm's warmth over a shift (truth): a first-order approach to the heat it is given, with
the drives' warm-up time constant; fully warm is 1, cold 0. It warms while a job runs (heat
1) and between jobs towards the share of that time it works on other parts (the shift's
`duty`), cooling where that is below its warmth."""

from __future__ import annotations

import math


def warmed(warmth: float, seconds: float, heat: float, tau_s: float) -> float:
    """The warmth after `seconds` [s] at `heat` (0 .. 1), from `warmth`, with time constant
    `tau_s` [s]."""
    return heat + (warmth - heat) * math.exp(-seconds / tau_s)


def warm_seconds(warmth: float, tau_s: float) -> float:
    """How long a cold arm runs to reach `warmth` (0 <= warmth < 1) [s]: the cell's
    `cell.noise.drives.warm_s` that starts a job at it."""
    if not 0.0 <= warmth < 1.0:
        raise ValueError(f"warmth must be in [0, 1), got {warmth!r}")
    return -tau_s * math.log1p(-warmth)
