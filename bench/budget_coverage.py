"""How well the error budget (scenarios.offline.error_budget) covers the true error: over runs of a
job, the share of targets whose true error is within their bound and of runs whose target
RMS is within the RMS bound; the runs the budget calls at risk, and those that end
`complete` with a goal missed; the coverage factors that would cover 95 %.

Usage: python bench/budget_coverage.py FOLDER [FOLDER ...] [--write NAME]
       python bench/budget_coverage.py --short [--page]

FOLDER is a folder of run folders (every results.json below it, e.g. `twincell run skull
--seed S --out FOLDER` for each seed). The runs' budgets are made again from their terms
with the budget's code and the job's and the cell's settings as they are now (the factors
`verify.budget`, the cell's arm figure), so a changed setting is measured on the same runs.
With --write NAME, each target's terms and true error go to bench/data/budget_NAME.csv.

--short: the sets kept in bench/data/budget_*.csv (docs/concepts/faults.md's figures; no
job is run): skull_calibration (seeds 76000-76039), skull (74000-74059), ur5 (the UR5
cell, 74000-74059), ur5e (examples/ur5e_cell.yaml, 74000-74059) and my_cell
(examples/my_cell, 74000-74059). With --page, the table
goes into docs/concepts/faults.md between its `<!-- table:budget -->` markers
(tests/test_budget.py checks the page against the sets).
"""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenarios.offline.error_budget import error_budget
from scenarios.offline.settings import PlanningSettings
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.run import RAN

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "bench" / "data"
PAGE = ROOT / "docs" / "concepts" / "faults.md"
COLUMNS = ("job", "cell", "seed", "status", "target", "error_m", "tre_m", "tool_m", "model_m",
           "calibration_residual_m")  # fmt: skip


@dataclass(frozen=True)
class Run:
    """One run: its job and cell, its targets' true errors [m] and its budget as the code
    and settings make it now."""

    job: str
    cell: str
    seed: int
    errors_m: np.ndarray
    budget: ErrorBudget

    @property
    def sigmas_m(self) -> np.ndarray:
        return np.array([t.sigma_m for t in self.budget.targets])

    @property
    def rms_m(self) -> float:
        return float(np.sqrt(np.mean(self.errors_m**2)))

    @property
    def missed(self) -> bool:
        b = self.budget
        return (b.goal_rms_m is not None and self.rms_m > b.goal_rms_m) or (
            b.goal_max_m is not None and float(self.errors_m.max()) > b.goal_max_m
        )


def _settings(
    job: str, cell: str, cache: dict[tuple[str, str], PlanningSettings]
) -> PlanningSettings:
    """The planning settings of `job` in `cell` ("-": the job's own) as they are now."""
    if (job, cell) not in cache:
        from scenarios.configuration.config_files import load_config

        beside = ROOT / cell  # a cell file of the repository (examples/...), from anywhere
        where = beside if cell != "-" and beside.is_file() else cell
        job_file = ROOT / job  # a job file of the repository, from anywhere
        config = load_config(
            job_file if job_file.is_file() else job, cell=None if cell == "-" else where
        )
        cache[(job, cell)] = config.planning()
    return cache[(job, cell)]


def read_folder(folder: Path, job: str, cell: str) -> list[dict[str, str]]:
    """The rows (COLUMNS) of every run below `folder` whose program ran with a budget."""
    rows = []
    for path in sorted(folder.rglob("results.json")):
        data = json.loads(path.read_text())
        budget = data.get("budget")
        if data["status"] not in RAN or not budget:
            continue
        errors = {t["name"]: t["error_m"] for t in data["targets"]}
        residual = data["calibration"].get("residual_rms_after_m")
        for t in budget["targets"]:
            rows.append({
                "job": job, "cell": cell, "seed": str(data["seed"]), "status": data["status"],
                "target": t["name"], "error_m": repr(errors[t["name"]]),
                "tre_m": repr(t["tre_m"]), "tool_m": repr(t["tool_m"]),
                "model_m": repr(t["model_m"]),
                "calibration_residual_m": "" if residual is None else repr(residual),
            })  # fmt: skip
    return rows


def runs_of(rows: list[dict[str, str]]) -> list[Run]:
    """The runs of `rows`, each budget made again with the settings of now."""
    cache: dict[tuple[str, str], PlanningSettings] = {}
    by_run: dict[tuple[str, str, str], list[dict[str, str]]] = {}
    for row in rows:
        by_run.setdefault((row["job"], row["cell"], row["seed"]), []).append(row)
    runs = []
    for (job, cell, seed), mine in by_run.items():
        residual = mine[0]["calibration_residual_m"]
        budget = error_budget(
            tuple(r["target"] for r in mine),
            np.array([float(r["tre_m"]) for r in mine]),
            np.array([float(r["model_m"]) for r in mine]),  # at least the stated floor
            float(mine[0]["tool_m"]),
            float(residual) if residual else None,
            _settings(job, cell, cache),
        )
        errors = np.array([float(r["error_m"]) for r in mine])
        runs.append(Run(job, cell, int(seed), errors, budget))
    return runs


def report(name: str, runs: list[Run], quantile: float = 0.95) -> str:
    """A table row of a set of runs."""
    ratios = np.concatenate([r.errors_m / r.sigmas_m for r in runs])
    rms_ratios = np.array([r.rms_m / float(np.sqrt(np.mean(r.sigmas_m**2))) for r in runs])
    covered = sum(int(np.sum(r.errors_m <= [t.bound_m for t in r.budget.targets])) for r in runs)
    rms_covered = sum(int(r.rms_m <= r.budget.rms_bound_m) for r in runs)
    at_risk = sum(not r.budget.within_reach for r in runs)
    claimed = sum(r.budget.within_reach and r.missed for r in runs)
    factors = f"{np.quantile(ratios, quantile):.2f} / {np.quantile(rms_ratios, quantile):.2f}"
    return (
        f"| {name} | {len(runs)} | {covered / len(ratios):.1%} | {rms_covered / len(runs):.1%} "
        f"| {at_risk} ({sum(not r.budget.within_reach and not r.missed for r in runs)}) "
        f"| {claimed} | {factors} |"
    )


HEADER = (
    "| set | runs | targets within their bound | runs' RMS within its bound | at risk (goals met) "
    "| complete, a goal missed | factors covering 95 % (target / RMS) |\n"
    "|---|---:|---:|---:|---:|---:|---:|"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", type=Path)
    parser.add_argument("--job", default="skull", help="the job the runs ran (default skull)")
    parser.add_argument("--cell", default="-", help="the cell they ran in (default: the job's)")
    parser.add_argument(
        "--write", metavar="NAME", help="keep the rows in bench/data/budget_NAME.csv"
    )
    parser.add_argument("--short", action="store_true", help="the sets kept in bench/data")
    parser.add_argument("--page", action="store_true", help="with --short: write the docs' table")
    args = parser.parse_args()
    if not args.short:
        if not args.folders:
            parser.error("give run folders, or --short")
        rows = [r for f in args.folders for r in read_folder(f, args.job, args.cell)]
        if not rows:
            raise SystemExit(f"no run with an error budget in {', '.join(map(str, args.folders))}")
        name = args.write or "runs"
        path = DATA / f"budget_{name}.csv"
        if args.write:
            with open(path, "w", newline="") as handle:
                writer = csv.DictWriter(handle, COLUMNS)
                writer.writeheader()
                writer.writerows(rows)
            print(f"wrote {path}")
        else:
            print(HEADER)
            print(report(name, runs_of(rows)))
            return
    table = kept_rows()
    print(HEADER)
    print("\n".join(table))
    if args.short and args.page:
        from bench_support.readme_table_rows import replace_table

        PAGE.write_text(replace_table(PAGE.read_text(), "budget", HEADER, table))
        print(f"wrote the table into {PAGE}")


def kept_rows() -> list[str]:
    """The table's rows of the sets kept in bench/data."""
    out = []
    for path in sorted(DATA.glob("budget_*.csv")):
        with open(path, newline="") as handle:
            out.append(
                report(path.stem.removeprefix("budget_"), runs_of(list(csv.DictReader(handle))))
            )
    return out


if __name__ == "__main__":
    main()
