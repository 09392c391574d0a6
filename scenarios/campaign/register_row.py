"""A register trial's row: typed as the trial made it, flattened to the results table's
columns once, where the campaign stores it (`RegisterRow.columns()`).

Lengths [m], angles [rad], times [s]. The columns, in order: what was scanned, the match's
figures, its errors against the truth, the targets (`n_targets`, their names joined by ";",
then `err_t<k>_m`, `tre_t<k>_m`, `ratio_t<k>` for each of the first MAX_TARGETS), each scan
fault's `fault.<name>` and `fault.<name>.stage`, `harmed`, and the times.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from registration.verdict import Verdict
from scenarios.results.edge import JsonObject

MAX_TARGETS = 8
"""Targets reported per trial (columns err_t0_m ... of the results table)."""

FaultOutcome = Literal["recovered", "stopped", "missed"]
"""A scan fault's outcome: seen and the match accepted (recovered) or not (stopped), or not
seen (missed)."""


@dataclass(frozen=True)
class TargetRecord:
    """One target of the trial: its name, its error against the truth (the virtual target
    placed by the estimated and by the true pose) [m], the matcher's predicted TRE there [m],
    and their ratio (inf where nothing was predicted)."""

    name: str
    error_m: float
    predicted_tre_m: float
    ratio: float


@dataclass(frozen=True)
class ScanFaultOutcome:
    """A scan fault of the trial (the job's name) and what came of it; `stage` is the stage
    that saw it ("register") or "missed"."""

    name: str
    outcome: FaultOutcome
    stage: Literal["register", "missed"]


@dataclass(frozen=True)
class RegisterRow:
    """The row of one register trial: what was scanned (`model` matched against,
    `scanned_model` on the table), the match's verdict and figures, its errors against the
    truth (`target_error_real_max_m`: against the real entity's targets, model error
    included), the targets, the scan faults and whether an accepted match harmed (a target
    beyond HARM_M), the match's and the trial's times."""

    case: str
    model: str
    scanned_model: str
    n_points: int
    surface_fraction: float
    outlier_fraction: float
    verdict: Verdict
    reason: str
    accepted: bool
    ambiguity: float
    rms_m: float
    inlier_fraction: float
    worst_predicted_tre_m: float
    rotation_error_rad: float
    centroid_error_m: float
    target_error_max_m: float
    target_error_mean_m: float
    target_error_real_max_m: float
    predicted_tre_max_m: float
    right_object: bool
    good: bool
    false_accept: bool
    targets: tuple[TargetRecord, ...]
    faults: tuple[ScanFaultOutcome, ...]
    harmed: bool
    match_seconds: float
    trial_seconds: float

    def columns(self) -> JsonObject:
        """The row as the results table's columns (flags as 0/1), in the table's order."""
        row: JsonObject = {
            "case": self.case,
            "model": self.model,
            "scanned_model": self.scanned_model,
            "n_points": self.n_points,
            "surface_fraction": self.surface_fraction,
            "outlier_fraction": self.outlier_fraction,
            "verdict": self.verdict,
            "reason": self.reason,
            "accepted": int(self.accepted),
            "ambiguity": self.ambiguity,
            "rms_m": self.rms_m,
            "inlier_fraction": self.inlier_fraction,
            "worst_predicted_tre_m": self.worst_predicted_tre_m,
            "rotation_error_rad": self.rotation_error_rad,
            "centroid_error_m": self.centroid_error_m,
            "target_error_max_m": self.target_error_max_m,
            "target_error_mean_m": self.target_error_mean_m,
            "target_error_real_max_m": self.target_error_real_max_m,
            "predicted_tre_max_m": self.predicted_tre_max_m,
            "right_object": int(self.right_object),
            "good": int(self.good),
            "false_accept": int(self.false_accept),
            "n_targets": len(self.targets),
            "targets": ";".join(t.name for t in self.targets),
        }
        for k, target in enumerate(self.targets[:MAX_TARGETS]):
            row[f"err_t{k}_m"] = target.error_m
            row[f"tre_t{k}_m"] = target.predicted_tre_m
            row[f"ratio_t{k}"] = target.ratio
        for fault in self.faults:
            row[f"fault.{fault.name}"] = fault.outcome
            row[f"fault.{fault.name}.stage"] = fault.stage
        row["harmed"] = int(self.harmed)
        row["match_seconds"] = self.match_seconds
        row["trial_seconds"] = self.trial_seconds
        return row
