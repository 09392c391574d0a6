"""What the controller's supervision and the stages' own checks saw during a run, and each
fault injected into the real cell with the stage that detected it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SupervisionEvent:
    """One thing the supervision or a stage's check saw: in `stage`, at `time_s` of the
    controller's clock [s], its `code` (e.g. "collision", "verification"), what it saw
    (`message`) and what it did (`action`); the figure it read and the limit it held it to
    (SI units; None where the check reads no figure, a switch or a stop)."""

    stage: str
    time_s: float
    code: str
    message: str
    action: str
    reading: float | None = None
    limit: float | None = None


@dataclass(frozen=True)
class Injection:
    """When a fault happened: the stage the run was in, the controller's clock [s], and
    what the injector did."""

    stage: str
    time_s: float
    what: str


#: A fault's `detected_by` when no check saw it, or when its occasion never came.
MISSED, NOT_INJECTED = "missed", "not injected"


@dataclass(frozen=True)
class FaultOutcome:
    """One fault of the run: its kind's `name`, `amount` (SI), the `stage` it was due in
    (None: from the start) and `option`; when it was injected (None: its occasion never
    came); the stage whose supervision or check saw it first (`detected_by`, or "missed",
    or "not injected") and by which symptom (a code of SupervisionEvent); for a fault that
    moves the object, how far it moved the farthest target (`target_move_m` [m], the
    truth), else None."""

    name: str
    amount: float
    stage: str | None
    option: str | None
    injected: Injection | None
    detected_by: str
    symptom: str | None = None
    target_move_m: float | None = None

    @property
    def detected(self) -> bool:
        return self.detected_by not in (MISSED, NOT_INJECTED)
