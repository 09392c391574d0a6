"""The scan's plan as results.json keeps it: how it was chosen, what it predicted, and the
cell time the scan then took."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PassSummary:
    """One pass of the plan: its name, tilt and heading [deg], offset, stand-off and table
    position [m], the worst predicted TRE after it (None: not finite) [m], its time [s], its
    share of the information, and whether the arm reaches it through home."""

    name: str
    tilt_deg: float
    heading_deg: float
    offset_m: float
    standoff_m: float
    table_position_m: float
    predicted_tre_max_m: float | None
    seconds: float
    information_share: float
    through_home: bool


@dataclass(frozen=True)
class ScanPlanSummary:
    """The plan's `mode` ("auto": chosen for the targets; "fixed": the configuration's
    passes), its passes and sweep speed [m/s], the scan's cell time [s] (None: it did not
    run), the predicted scan time [s] and TRE at each target [m], the candidates it chose
    from, and the chosen passes."""

    mode: str
    passes: int
    sweep_speed_m_s: float
    scan_time_s: float | None
    predicted_scan_time_s: float
    predicted_tre_max_m: float
    predicted_tre_m: tuple[float, ...]
    candidates: int
    chosen: tuple[PassSummary, ...]

    @property
    def through_home(self) -> int:
        """How many passes the arm reaches through home."""
        return sum(c.through_home for c in self.chosen)
