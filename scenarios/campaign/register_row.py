"""A register trial's row: typed as the trial made it, flattened to the results table's
columns once, where the campaign stores it (by the results' converter,
scenarios.results.json_converter, with the layout registered here).

Lengths [m], angles [rad], times [s]. The columns, in order: what was scanned, the match's
figures, its errors against the truth, the targets (`n_targets`, their names joined by ";",
then `err_t<k>_m`, `tre_t<k>_m`, `ratio_t<k>` for each of the first MAX_TARGETS), each scan
fault's `fault.<name>` and `fault.<name>.stage`, `harmed`, and the times.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from cattrs.gen import override

from registration.verdict import Verdict
from scenarios.results.edge import JsonObject
from scenarios.results.json_converter import register_writer

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


def _target_and_fault_columns(row: RegisterRow) -> JsonObject:
    """The targets' columns (their count, their names joined by ";", then each of the first
    MAX_TARGETS's error, predicted TRE and ratio) and each scan fault's outcome and stage."""
    out: JsonObject = {
        "n_targets": len(row.targets),
        "targets": ";".join(t.name for t in row.targets),
    }
    for k, target in enumerate(row.targets[:MAX_TARGETS]):
        out[f"err_t{k}_m"] = target.error_m
        out[f"tre_t{k}_m"] = target.predicted_tre_m
        out[f"ratio_t{k}"] = target.ratio
    for fault in row.faults:
        out[f"fault.{fault.name}"] = fault.outcome
        out[f"fault.{fault.name}.stage"] = fault.stage
    return out


_FLAG = override(unstruct_hook=int)
"""A flag as the results table holds it: 0 or 1."""
register_writer(
    RegisterRow,
    keys="... harmed match_seconds trial_seconds",
    derived=_target_and_fault_columns,
    targets=override(omit=True),
    faults=override(omit=True),
    accepted=_FLAG,
    right_object=_FLAG,
    good=_FLAG,
    false_accept=_FLAG,
    harmed=_FLAG,
)
