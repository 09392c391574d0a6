"""The campaign report: figures aggregated from the results table alone (results.csv).

Per sweep point and over all trials: verdicts, acceptance of good registrations, false
accepts (accepted with the wrong object or a target error beyond the threshold), the target
error of accepted registrations, the calibration of the predicted TRE (measured / predicted,
per target, over accepted registrations of the right object) and the run time.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from models.atomic import write_text
from scenarios.campaign.plots import write_plots
from scenarios.campaign.rows import CALIBRATION_GOAL, group_rows, json_ready, per_target, quantiles
from scenarios.campaign.shift_report import SHIFT_NOTE, write_shift_report
from scenarios.campaign.store import read_csv
from scenarios.results.edge import JsonObject

STAGE_NOTES = {
    "register": (
        "Stage: register only. Each trial simulates a laser scan of the real object (model "
        "error, range noise, arm offsets per pass) at a random pose and matches it to the "
        "virtual model; no cell, no robot motion, no program execution."
    ),
    "full": "Stage: full. Each trial runs the whole scenario headless in the simulated cell.",
    "shift": SHIFT_NOTE,
}


def _floats(rows: list[dict[str, str]], column: str) -> np.ndarray:
    values = [float(r[column]) for r in rows if r.get(column, "") not in ("", None)]
    return np.array(values, dtype=float)


@dataclass(frozen=True)
class GroupSummary:
    """Aggregated figures of a group of trials (a sweep point, or all). Lengths [m], times [s].

    `errors`: trials stopped by a user error (status "error": a configuration or input the
    trial cannot use); `crashes`: trials stopped by a program error (status "crash", a bug:
    the traceback is in the trial's folder); the other figures are over the trials that
    returned a row (status "ok", refused and aborted runs included).
    `acceptance_of_good`: accepted / good (right object, every target within the threshold);
    `target_error`: quantiles over every target of the accepted registrations;
    `tre_ratio`: quantiles of measured / predicted TRE over every target of the accepted
    registrations of the right object.
    """

    label: str
    trials: int
    errors: int
    crashes: int
    accepted: int
    ambiguous: int
    rejected: int
    good: int
    good_accepted: int
    false_accepts: int
    acceptance_of_good: float
    target_error: dict[str, float]
    tre_ratio: dict[str, float]
    trial_seconds: dict[str, float]
    exported_rms: dict[str, float]
    exported_met: int
    job_rms: dict[str, float]
    faults: dict[str, dict[str, int]]
    harmed: int


def summarize(rows: list[dict[str, str]], label: str) -> GroupSummary:
    """Aggregate the rows (strings, as read from the CSV) of one group."""
    ok = [r for r in rows if r.get("status") == "ok"]
    flag = lambda r, c: r.get(c, "") not in ("", "0", "False")  # noqa: E731
    accepted = [r for r in ok if flag(r, "accepted")]
    good = [r for r in ok if flag(r, "good")]
    good_accepted = [r for r in good if flag(r, "accepted")]
    right_accepted = [r for r in accepted if flag(r, "right_object")]
    return GroupSummary(
        label=label,
        trials=len(rows),
        errors=sum(r.get("status") == "error" for r in rows),
        crashes=sum(r.get("status") == "crash" for r in rows),
        accepted=len(accepted),
        ambiguous=sum(r.get("verdict") == "ambiguous" for r in ok),
        rejected=sum(r.get("verdict") == "rejected" for r in ok),
        good=len(good),
        good_accepted=len(good_accepted),
        false_accepts=sum(flag(r, "false_accept") for r in ok),
        acceptance_of_good=len(good_accepted) / len(good) if good else math.nan,
        target_error=quantiles(per_target(accepted, "err_t", "_m")),
        tre_ratio=quantiles(per_target(right_accepted, "ratio_t", "")),
        trial_seconds=quantiles(_floats(rows, "trial_seconds")),
        exported_rms=quantiles(_floats(ok, "exported_rms_m")),
        exported_met=sum(
            float(r["exported_rms_m"]) <= PROGRAM_GOALS[0]
            and float(r["exported_max_m"]) <= PROGRAM_GOALS[1]
            for r in ok
            if r.get("exported_rms_m", "") not in ("", None)
            and r.get("exported_max_m", "") not in ("", None)
        ),
        job_rms=quantiles(_floats(ok, "job_rms_m")),
        faults=fault_counts(ok),
        harmed=sum(flag(r, "harmed") for r in ok),
    )


OUTCOMES = ("recovered", "stopped", "missed", "not injected")


def fault_counts(rows: list[dict[str, str]]) -> dict[str, dict[str, int]]:
    """Per fault kind: the trials it was set in, each outcome's count (OUTCOMES), and how
    many of its runs completed with a target beyond the goal (`harmed`); detections by
    stage as `by <stage>`."""
    names = sorted(
        {
            c.removeprefix("fault.")
            for r in rows
            for c in r
            if c.startswith("fault.") and "." not in c.removeprefix("fault.")
        }
    )
    out: dict[str, dict[str, int]] = {}
    for name in names:
        mine = [r for r in rows if r.get(f"fault.{name}", "") not in ("", None)]
        counts = {"trials": len(mine)} | {o: 0 for o in OUTCOMES}
        for r in mine:
            counts[r[f"fault.{name}"]] += 1
            if r[f"fault.{name}"] in ("recovered", "stopped"):
                by = f"by {r.get(f'fault.{name}.stage', '')}"
                counts[by] = counts.get(by, 0) + 1
        counts["harmed"] = sum(r.get("harmed", "") not in ("", "0") for r in mine)
        out[name] = counts
    return out


def _mm(x: float) -> str:
    return "-" if math.isnan(x) else f"{x * 1e3:.3f}"


def _num(x: float, digits: int = 2) -> str:
    return "-" if math.isnan(x) else f"{x:.{digits}f}"


def markdown(summaries: list[GroupSummary], stage: str) -> str:
    """The report as Markdown: the stage note, the goals, one table row per group."""
    total = summaries[-1]
    lo, hi = CALIBRATION_GOAL
    median = total.tre_ratio["median"]
    lines = [
        "# Campaign report",
        "",
        STAGE_NOTES.get(stage, f"Stage: {stage}."),
        "",
        f"- trials: {total.trials} ({total.errors} failed, {total.crashes} crashed)",
        f"- false accepts: {total.false_accepts} (goal 0)",
        f"- acceptance of good registrations: {total.good_accepted}/{total.good}"
        f" = {_num(total.acceptance_of_good * 100, 1)} %",
        f"- predicted TRE calibration, median measured/predicted: {_num(median)} "
        f"(goal within [{lo}, {hi}]: {'met' if lo <= median <= hi else 'not met'})",
        "",
        "| group | trials | failed | crashed | accepted | ambiguous | rejected | false accepts | "
        "accepted good | target error median / q95 / max [mm] | TRE ratio q25 / median / q75 "
        "| trial time median / q95 [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    exported = _exported_lines(summaries)
    if exported:
        lines[8:8] = exported
    for s in summaries:
        lines.append(
            f"| {s.label} | {s.trials} | {s.errors} | {s.crashes} | {s.accepted} | {s.ambiguous} | "
            f"{s.rejected} | {s.false_accepts} | {s.good_accepted}/{s.good} | "
            f"{_mm(s.target_error['median'])} / {_mm(s.target_error['q95'])} / "
            f"{_mm(s.target_error['max'])} | {_num(s.tre_ratio['q25'])} / "
            f"{_num(s.tre_ratio['median'])} / {_num(s.tre_ratio['q75'])} | "
            f"{_num(s.trial_seconds['median'])} / {_num(s.trial_seconds['q95'])} |"
        )
    lines.extend(_fault_lines(total, stage))
    return "\n".join(lines) + "\n"


def _fault_lines(total: GroupSummary, stage: str) -> list[str]:
    """The faults' table (trials with faults): per kind, how often it was detected (and by
    which stage), recovered, stopped safely or missed, and how many of its trials went on
    (a complete run; in the register stage, an accepted match) with a target beyond the
    goal."""
    if not total.faults:
        return []
    went_on = "accepted matches" if stage == "register" else "complete runs"
    lines = [
        "",
        "## Faults",
        "",
        f"- {went_on} with a target error beyond 1 mm: {total.harmed} (goal 0)",
        "",
        "| fault | trials | detected (by stage) | recovered | stopped | missed | not injected "
        f"| {went_on} beyond 1 mm |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, c in total.faults.items():
        by = ", ".join(f"{k.removeprefix('by ')} {v}" for k, v in c.items() if k.startswith("by "))
        detected = c["recovered"] + c["stopped"]
        lines.append(
            f"| {name} | {c['trials']} | {detected} ({by or '-'}) | {c['recovered']} | "
            f"{c['stopped']} | {c['missed']} | {c['not injected']} | {c['harmed']} |"
        )
    return lines


#: The skull job's goals for a program's target errors: RMS and max [m].
PROGRAM_GOALS = (0.5e-3, 1.0e-3)


def _exported_lines(summaries: list[GroupSummary]) -> list[str]:
    """Lines on the exported program run by a controller without absolute accuracy (full
    stage): in how many trials it met the goals, and its target error RMS."""
    total = summaries[-1]
    if not total.exported_rms.get("n"):
        return []
    rms_goal, max_goal = PROGRAM_GOALS
    q = total.exported_rms
    return [
        f"- exported program on a controller without absolute accuracy: goals (RMS <= "
        f"{rms_goal * 1e3:g} mm, max <= {max_goal * 1e3:g} mm) met in {total.exported_met}/"
        f"{q['n']} trials; target RMS median {_mm(q['median'])}, q95 {_mm(q['q95'])}, max "
        f"{_mm(q['max'])} mm; the job's own execution: RMS median "
        f"{_mm(total.job_rms['median'])}, max {_mm(total.job_rms['max'])} mm",
    ]


def campaign_summaries(csv_path: str | Path, keys: list[str]) -> list[GroupSummary]:
    """One summary per sweep point and the last one over all trials, from the CSV alone."""
    rows = read_csv(csv_path)
    summaries = [summarize(group, label) for label, group in group_rows(rows, keys)] if keys else []
    return [*summaries, summarize(rows, "all")]


def write_report(folder: Path, csv_path: Path, stage: str, keys: list[str]) -> list[Path]:
    """Write report.md, report.json and the figures of the campaign in `folder` (a shift
    campaign's: scenarios.campaign.shift_report)."""
    if stage == "shift":
        return write_shift_report(folder, read_csv(csv_path), keys)
    summaries = campaign_summaries(csv_path, keys)
    data: JsonObject = {
        "stage": stage,
        "note": STAGE_NOTES.get(stage, ""),
        "calibration_goal": list(CALIBRATION_GOAL),
        "groups": [asdict(s) for s in summaries],
    }
    files = [
        write_text(folder / "report.md", markdown(summaries, stage)),
        write_text(folder / "report.json", json.dumps(json_ready(data), indent=2)),
    ]

    files.extend(write_plots(folder, read_csv(csv_path), keys))
    return files
