"""The localization's part of a run's result: the surface match's figures (`MatchReport`) and
each localization method's pose, targets and verdict (`MethodReport`), with their JSON in
results.json ("registration" and "methods", see scenarios.results.run).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.results.edge import JsonObject, unbounded
from scenarios.results.evaluations import PoseEvaluation, TargetEvaluation
from scenarios.results.json_converter import structure, unstructure


@dataclass(frozen=True, eq=False)
class MatchReport:
    """The surface match: its figures (registration.MatchResult) and the pose it gave,
    T_table_object (4, 4)."""

    rms_m: float
    ambiguity: float
    verdict: str
    reason: str
    seconds: float
    points_used: int
    inlier_fraction: float
    T_table_object: np.ndarray
    starts: int = 1

    def to_json(self) -> JsonObject:
        return {
            "rms_m": self.rms_m,
            "ambiguity": self.ambiguity,
            "verdict": self.verdict,
            "reason": self.reason,
            "seconds": self.seconds,
            "points_used": self.points_used,
            "inlier_fraction": self.inlier_fraction,
            "T_table_object": self.T_table_object.tolist(),
            "starts": self.starts,
        }

    @classmethod
    def from_json(cls, data: JsonObject) -> MatchReport:
        return cls(
            float(data["rms_m"]),
            float(data["ambiguity"]),
            str(data["verdict"]),
            str(data["reason"]),
            float(data["seconds"]),
            int(data["points_used"]),
            float(data["inlier_fraction"]),
            np.array(data["T_table_object"], dtype=float),
            int(data["starts"]),
        )


@dataclass(frozen=True, eq=False)
class MethodReport:
    """One localization method: its pose against the truth (None if it found none), whether
    its pose was accepted and why not, the targets executed with its pose, the predicted TRE
    at each target [m] (surface matching only), and the IR readings (probing only)."""

    method: str
    accepted: bool
    reason: str
    pose: PoseEvaluation | None
    targets: tuple[TargetEvaluation, ...] = ()
    predicted_tre_m: tuple[float, ...] = ()
    readings: int | None = None

    def errors(self) -> np.ndarray:
        """Achieved tip errors of the method's targets (K,) [m]."""
        return np.array([t.error_m for t in self.targets])

    @property
    def rms_m(self) -> float | None:
        return _rms(self.errors())

    @property
    def max_m(self) -> float | None:
        errors = self.errors()
        return float(errors.max()) if len(errors) else None

    def predicted(self, name: str) -> float | None:
        """The predicted TRE at the target `name` [m], or None."""
        by_name = dict(zip((t.name for t in self.targets), self.predicted_tre_m, strict=False))
        return by_name.get(name)

    def to_json(self) -> JsonObject:
        out: JsonObject = {
            "accepted": self.accepted,
            "reason": self.reason,
            "rotation_error_deg": None if self.pose is None else self.pose.rotation_error_deg,
            "translation_error_m": None if self.pose is None else self.pose.translation_error_m,
            "targets": [unstructure(t) for t in self.targets],
            "predicted_tre_m": list(self.predicted_tre_m),
            "target_error_rms_m": self.rms_m,
            "target_error_max_m": self.max_m,
        }
        if self.readings is not None:
            out["ir_readings"] = self.readings
        return out

    @classmethod
    def from_json(cls, method: str, data: JsonObject) -> MethodReport:
        rotation = data["rotation_error_deg"]
        pose = None
        if rotation is not None:
            pose = PoseEvaluation(float(rotation), float(data["translation_error_m"]))
        return cls(
            method,
            bool(data["accepted"]),
            str(data["reason"]),
            pose,
            tuple(structure(t, TargetEvaluation) for t in data["targets"]),
            tuple(unbounded(t) for t in data["predicted_tre_m"]),
            data.get("ir_readings"),
        )


def _rms(errors: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(errors**2))) if len(errors) else None
