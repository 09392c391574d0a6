"""The scan's plan as results.json keeps it: how it was chosen, what it predicted, and the
cell time the scan then took."""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.results.edge import JsonObject, unbounded


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

    def to_json(self) -> JsonObject:
        return dict(self.__dict__)

    @classmethod
    def from_json(cls, data: JsonObject) -> PassSummary:
        return cls(**data)


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

    def to_json(self) -> JsonObject:
        return {
            **{k: v for k, v in self.__dict__.items() if k not in ("predicted_tre_m", "chosen")},
            "predicted_tre_m": list(self.predicted_tre_m),
            "chosen": [c.to_json() for c in self.chosen],
        }

    @classmethod
    def from_json(cls, data: JsonObject) -> ScanPlanSummary:
        skip = ("predicted_tre_m", "chosen", "predicted_tre_max_m")
        return cls(
            **{k: v for k, v in data.items() if k not in skip},
            predicted_tre_max_m=unbounded(data["predicted_tre_max_m"]),
            predicted_tre_m=tuple(unbounded(t) for t in data["predicted_tre_m"]),
            chosen=tuple(PassSummary.from_json(c) for c in data["chosen"]),
        )
