"""What the controller's supervision and the stages' own checks saw during a run, and each
fault injected into the real cell with the stage that detected it."""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.results.edge import JsonObject


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

    def to_json(self) -> JsonObject:
        return {
            "stage": self.stage,
            "time_s": self.time_s,
            "code": self.code,
            "message": self.message,
            "action": self.action,
            "reading": self.reading,
            "limit": self.limit,
        }

    @classmethod
    def from_json(cls, data: JsonObject) -> SupervisionEvent:
        return cls(
            str(data["stage"]),
            float(data["time_s"]),
            str(data["code"]),
            str(data["message"]),
            str(data["action"]),
            data.get("reading"),
            data.get("limit"),
        )


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

    def to_json(self) -> JsonObject:
        out: JsonObject = {
            "name": self.name,
            "amount": self.amount,
            "stage": self.stage,
            "option": self.option,
        }
        if self.injected is None:
            return out | {"injected": None, "detected_by": self.detected_by}
        i = self.injected
        return out | {
            "injected": {"stage": i.stage, "time_s": i.time_s, "what": i.what},
            "detected_by": self.detected_by,
            "symptom": self.symptom,
            "target_move_m": self.target_move_m,
        }

    @classmethod
    def from_json(cls, data: JsonObject) -> FaultOutcome:
        i = data["injected"]
        injected = None if i is None else Injection(str(i["stage"]), float(i["time_s"]), i["what"])
        return cls(
            str(data["name"]),
            float(data["amount"]),
            data["stage"],
            data["option"],
            injected,
            str(data["detected_by"]),
            data.get("symptom"),
            data.get("target_move_m"),
        )
