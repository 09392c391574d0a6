"""The operating curve of a check that guards a job against a fault: over a campaign that
varies the fault's amount (`--vary faults.<name>=0,...`), per amount how often the fault was
detected, how often it was beyond what the job's goal allows, and how often a run ended
complete with its RMS goal missed while the fault went unseen. The amount 0 gives the false
alarms.

A fault's size at the targets is the truth's: for a bump, how far it moved the farthest
target (`fault.<name>.target_move_m`); for a tool seated off, its amount (it moves every
target by as much); for the other faults it is not known (a table that stalls short with a
lying readout moves the targets only if the table moves again between the scan and the
program), and they have no "beyond the goal" count.

A complete run that missed its RMS goal while the fault went unseen counts against the
fault only if the same seed (the same trial of the campaign) met the goal without it: a
run whose own error is beyond the goal did not miss it because of the fault.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from dataclasses import dataclass

from scenarios.results.run import RAN

#: A campaign row as results.csv holds it.
Row = dict[str, str]
#: The outcomes of a fault that count as detected (fault_columns).
DETECTED = ("recovered", "stopped")
#: The faults whose amount is their size at the targets [m].
SIZE_IS_AMOUNT = ("tool_lock_fail",)
#: An amount at or below this [m] is no fault: its detections are false alarms (a tool's
#: seat offset of 0 means no lock at all, so its curve starts at 1 um).
NO_FAULT_M = 1.0e-5


@dataclass(frozen=True)
class CurvePoint:
    """One amount [m] of the fault: its trials, how many detected it; those whose size at
    the targets [m] was beyond the goal and how many of them were detected; the runs that
    ended complete with the RMS goal missed, and of them those where the fault went unseen;
    the runs that ran their program but said a goal was at risk (their error budget's
    bound beyond it, scenarios.offline.error_budget); the median target RMS of the runs that ran
    their program, complete or at risk [m] (nan: none) and the verification's median cell
    time [s] (nan: none)."""

    amount_m: float
    trials: int
    detected: int
    beyond_goal: int
    beyond_goal_detected: int
    rms_missed: int
    rms_missed_unseen: int
    at_risk: int
    rms_median_m: float
    verify_time_s: float

    @property
    def rate(self) -> float:
        return self.detected / self.trials if self.trials else float("nan")


@dataclass(frozen=True)
class OperatingCurve:
    """The curve of fault `fault` against the RMS goal `goal_m` [m], by amount."""

    fault: str
    goal_m: float
    points: tuple[CurvePoint, ...]

    @property
    def false_alarm_rate(self) -> float:
        """Detections at amount 0 (or below NO_FAULT_M) over its trials (nan: none)."""
        zero = [p for p in self.points if p.amount_m <= NO_FAULT_M]
        return zero[0].rate if zero else float("nan")

    @property
    def beyond_goal_rate(self) -> float:
        """Detected of the faults beyond the goal at the targets (nan: none was, or their
        size is not known)."""
        n = sum(p.beyond_goal for p in self.points)
        return sum(p.beyond_goal_detected for p in self.points) / n if n else float("nan")

    @property
    def rms_missed_unseen(self) -> int:
        return sum(p.rms_missed_unseen for p in self.points if p.amount_m > NO_FAULT_M)

    def meets(self, detect: float = 0.95, false_alarms: float = 0.05) -> list[str]:
        """What misses the goals: at least `detect` of the faults beyond the goal detected, at
        most `false_alarms` at amount 0, no complete run with its RMS goal missed while a
        fault went unseen. Empty: all met."""
        out = []
        if self.beyond_goal_rate == self.beyond_goal_rate and self.beyond_goal_rate < detect:
            out.append(f"{self.beyond_goal_rate:.1%} of the faults beyond the goal detected")
        if not self.false_alarm_rate <= false_alarms:
            out.append(f"{self.false_alarm_rate:.1%} false alarms at 0")
        if self.rms_missed_unseen:
            out.append(f"{self.rms_missed_unseen} complete runs missed the RMS goal unseen")
        return out

    def table(self, unit: str = "mm") -> list[str]:
        """The curve as README rows (markdown), one per amount."""
        rows = [
            f"| {self.fault} [{unit}] | trials | detected | beyond the goal at a target "
            "(detected) | complete, RMS goal missed (fault unseen, goal met without it) | "
            "at risk | target RMS, median "
            "[mm] | verification's cell time, median [s] |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        sized = self.fault in SIZE_IS_AMOUNT or self.fault == "object_bump"
        for p in self.points:
            beyond = f"{p.beyond_goal} ({p.beyond_goal_detected})" if sized else "-"
            rows.append(
                f"| {p.amount_m * 1e3:g} | {p.trials} | {p.detected} ({p.rate:.0%}) | "
                f"{beyond} | {p.rms_missed} "
                f"({p.rms_missed_unseen}) | {p.at_risk} | {_mm(p.rms_median_m)} | "
                f"{_num(p.verify_time_s)} |"
            )
        return rows


def operating_curve(rows: Sequence[Row], fault: str, goal_m: float) -> OperatingCurve:
    """The curve of `fault` over a campaign's `rows` (results.csv), the column
    `vary.faults.<fault>` its amount [m], against the RMS goal `goal_m` [m]."""
    column = f"vary.faults.{fault}"
    if not rows or column not in rows[0]:
        found = ", ".join(c for c in (rows[0] if rows else ()) if c.startswith("vary.")) or "none"
        raise ValueError(f"no column {column!r} in the campaign's rows; varied: {found}")
    amounts = sorted({_amount(r[column]) for r in rows})
    met_without = {
        r.get("trial", ""): _float(r.get("job_rms_m")) <= goal_m
        for r in rows
        if _amount(r[column]) <= NO_FAULT_M and r.get("run_status") == "complete"
    }
    return OperatingCurve(
        fault,
        goal_m,
        tuple(_point(rows, column, fault, a, goal_m, met_without) for a in amounts),
    )


def _point(
    rows: Sequence[Row],
    column: str,
    fault: str,
    amount: float,
    goal: float,
    met_without: dict[str, bool],
) -> CurvePoint:
    """The curve at `amount` [m]; `met_without`: per trial, whether the run without the
    fault met the goal."""
    mine = [r for r in rows if _amount(r[column]) == amount and r.get("status") == "ok"]
    detected = [r.get(f"fault.{fault}") in DETECTED for r in mine]
    size = [_size(r, fault, amount) for r in mine]
    ran = [r for r in mine if r.get("run_status") in RAN]
    missed = [
        (r, d)
        for r, d in zip(mine, detected, strict=True)
        if r.get("run_status") == "complete" and _float(r.get("job_rms_m")) > goal
    ]
    rms = [_float(r.get("job_rms_m")) for r in ran]
    times = [_float(r.get("verify_scan_time_s")) for r in mine if r.get("verify_scan_time_s")]
    return CurvePoint(
        amount_m=amount,
        trials=len(mine),
        detected=sum(detected),
        beyond_goal=sum(s > goal for s in size),
        beyond_goal_detected=sum(s > goal and d for s, d in zip(size, detected, strict=True)),
        rms_missed=len(missed),
        rms_missed_unseen=sum(
            not d and met_without.get(r.get("trial", ""), True) for r, d in missed
        ),
        at_risk=sum(r.get("run_status") == "at_risk" for r in mine),
        rms_median_m=statistics.median(rms) if rms else float("nan"),
        verify_time_s=statistics.median(times) if times else float("nan"),
    )


def _size(row: Row, fault: str, amount: float) -> float:
    """The fault's size at the targets [m], nan if not known (see the module's docstring)."""
    moved = row.get(f"fault.{fault}.target_move_m")
    if moved not in (None, ""):
        return _float(moved)
    return amount if fault in SIZE_IS_AMOUNT else float("nan")


def _amount(value: str) -> float:
    """A varied fault's amount [m]: a number, or "AMOUNT:OPTION"."""
    return float(value.partition(":")[0])


def _float(value: str | None) -> float:
    return float(value) if value not in (None, "") else float("nan")


def _mm(x: float) -> str:
    return "-" if x != x else f"{x * 1e3:.2f}"


def _num(x: float) -> str:
    return "-" if x != x else f"{x:.1f}"
