"""The localization's part of a run's result: the surface match's figures (`MatchReport`) and
each localization method's pose, targets and verdict (`MethodReport`), with their JSON in
results.json ("registration" and "methods": scenarios.results.json_converter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.results.evaluations import PoseEvaluation, TargetEvaluation


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


def _rms(errors: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(errors**2))) if len(errors) else None
