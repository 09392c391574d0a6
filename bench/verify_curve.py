"""The operating curves of the checks that guard the skull job against a fault after its
scan (scenarios.campaign.operating_curve): a campaign's rows in, docs/benchmarks.md's table and
figure out.

Usage: python bench/verify_curve.py CAMPAIGN_FOLDER --fault NAME [--cell LABEL] [--goal-mm 0.5]
                                     [--write]
       python bench/verify_curve.py --short

CAMPAIGN_FOLDER is a `twincell campaign skull --stage full --vary faults.NAME=...` run (its
results.csv). Prints the curve's table and whether it meets the goals (at least 95 % of the
faults beyond the goal at a target detected, at most 5 % false alarms at 0, no complete run
with its RMS goal missed while the fault went unseen). With --write: the rows the curve needs
go to bench/data/verify_NAME.csv, the figure to bench/data/verify_NAME.png and the table
into docs/benchmarks.md between its `<!-- table:verify_NAME -->` markers (tests/test_verify_curve.py
checks the page's table against that CSV). A campaign in another cell (`twincell campaign
... --cell ur5`) is kept as verify_NAME.LABEL with `--cell LABEL`.

--short: the curves of the campaigns kept in bench/data/ (no campaign is run).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from bench_support.readme_table_rows import replace_table

from scenarios.campaign.operating_curve import (
    DETECTED,
    SIZE_IS_AMOUNT,
    OperatingCurve,
    Row,
    operating_curve,
)

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "bench" / "data"
PAGE = ROOT / "docs" / "benchmarks.md"
#: The columns of a campaign's rows the curve and its figure need.
COLUMNS = (
    "trial", "seed", "status", "run_status", "job_rms_m", "job_max_m", "verify_runs",
    "verify_agrees", "verify_resolved", "verify_strips", "verify_scan_time_s",
    "verify_moved_max_m", "verify_uncertainty_max_m", "verify_allowance_min_m",
    "cell_time_s", "tool_off_m", "tool_checks", "tool_tolerance_m",
)  # fmt: skip


def fault_columns(fault: str) -> tuple[str, ...]:
    return (
        f"vary.faults.{fault}",
        f"fault.{fault}",
        f"fault.{fault}.stage",
        f"fault.{fault}.target_move_m",
    )


def trimmed(rows: list[Row], fault: str) -> list[Row]:
    """The rows with the columns the curve needs (missing ones empty)."""
    keep = (*fault_columns(fault), *COLUMNS)
    return [{c: r.get(c, "") for c in keep} for r in rows]


def read_rows(path: Path) -> list[Row]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


#: Per fault: the column of the check's reading and of its tolerance, and what they are.
READINGS = {
    "object_bump": ("verify_moved_max_m", "verify_allowance_min_m", "largest move measured"),
    "table_stall": ("verify_moved_max_m", "verify_allowance_min_m", "largest move measured"),
    "tool_lock_fail": ("tool_off_m", "tool_tolerance_m", "tool offset measured at the beam"),
}


def kept_name(fault: str, cell: str | None) -> str:
    """The name a curve is kept under: verify_FAULT, or verify_FAULT.CELL for another cell."""
    return f"verify_{fault}" if cell is None else f"verify_{fault}.{cell}"


def kept_fault(path: Path) -> str:
    """The fault of a kept curve's CSV (kept_name's inverse)."""
    return path.stem.removeprefix("verify_").partition(".")[0]


def _size_mm(row: Row, fault: str) -> float:
    """The fault's size at the targets [mm] (operating_curve's): a bump's farthest target
    move, else the amount."""
    moved = row.get(f"fault.{fault}.target_move_m")
    raw = moved if moved else row[f"vary.faults.{fault}"].partition(":")[0]
    return float(raw) * 1e3


def figure(curve: OperatingCurve, rows: list[Row], path: Path) -> None:
    """Left: the detection rate per amount. Right: the check's reading against the fault's
    size at the targets (the truth's), each run coloured by its outcome."""
    fault = curve.fault
    reading, tolerance, what = READINGS[fault]
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    amounts = [p.amount_m * 1e3 for p in curve.points]
    left.plot(amounts, [100 * p.rate for p in curve.points], "o-", color="tab:blue")
    left.axhline(95, color="grey", lw=0.8, ls="--")
    left.axhline(5, color="grey", lw=0.8, ls="--")
    left.set_xlabel(f"{fault} amount [mm]")
    left.set_ylabel("detected [%]")
    left.set_ylim(-3, 103)
    left.set_title(f"detection rate ({curve.points[0].trials} runs per amount)")
    for seen, colour, label in ((True, "tab:green", "detected"), (False, "tab:red", "unseen")):
        pts = [
            (_size_mm(r, fault), float(r[reading]) * 1e3)
            for r in rows
            if r.get(reading) and (r[f"fault.{fault}"] in DETECTED) == seen
        ]
        if pts:
            x, y = zip(*pts, strict=True)
            right.scatter(x, y, s=10, color=colour, label=label)
    limits = [float(r[tolerance]) * 1e3 for r in rows if r.get(tolerance)]
    if limits:
        right.axhline(min(limits), color="grey", lw=0.8, ls="--", label="least tolerance")
    right.axvline(curve.goal_m * 1e3, color="black", lw=0.8, ls=":", label="RMS goal")
    top = max((_size_mm(r, fault) for r in rows), default=1.0)
    right.plot([0, top], [0, top], color="grey", lw=0.5)
    sized = fault == "object_bump" or fault in SIZE_IS_AMOUNT
    right.set_xlabel(
        "the fault's size at the targets (truth) [mm]" if sized else f"{fault} amount [mm]"
    )
    right.set_ylabel(f"{what} [mm]")
    right.legend(fontsize=8)
    right.set_title("the check's reading against the truth, per run")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("campaign", type=Path, nargs="?")
    parser.add_argument("--fault")
    parser.add_argument("--cell", help="the cell's label, for a campaign in another cell")
    parser.add_argument("--goal-mm", type=float, default=0.5)
    parser.add_argument("--write", action="store_true")
    parser.add_argument("--short", action="store_true")
    args = parser.parse_args()
    if args.short:
        for kept in sorted(DATA.glob("verify_*.csv")):
            fault = kept_fault(kept)
            print(kept.stem)
            curve = operating_curve(read_rows(kept), fault, args.goal_mm * 1e-3)
            print("\n".join(curve.table()), end="\n\n")
        return
    if args.campaign is None or args.fault is None:
        parser.error("give a campaign's folder (or its results.csv) and --fault, or --short")
    source = args.campaign / "results.csv" if args.campaign.is_dir() else args.campaign
    rows = trimmed(read_rows(source), args.fault)
    curve = operating_curve(rows, args.fault, args.goal_mm * 1e-3)
    table = curve.table()
    print("\n".join(table))
    print(
        f"faults beyond the goal detected: {curve.beyond_goal_rate:.1%}; false alarms at 0: "
        f"{curve.false_alarm_rate:.1%}; complete runs with the RMS goal missed unseen: "
        f"{curve.rms_missed_unseen}"
    )
    missed = curve.meets()
    print("goals met" if not missed else "goals missed: " + "; ".join(missed))
    if args.write:
        DATA.mkdir(exist_ok=True)
        name = kept_name(args.fault, args.cell)
        out = DATA / f"{name}.csv"
        with out.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        figure(curve, rows, DATA / f"{name}.png")
        PAGE.write_text(replace_table(PAGE.read_text(), name, table[0], table[1:]))
        print(f"wrote {out}, {out.with_suffix('.png')} and docs/benchmarks.md's table {name}")


if __name__ == "__main__":
    main()
