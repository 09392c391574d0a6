"""How well the error budget (scenarios.offline.budget) covers the true error: over runs of a
job, the share of targets whose true error is within their bound and of runs whose target
RMS is within the RMS bound, at the coverage factors the runs were made with; the factors
that would cover 95 % (the calibration of `verify.budget`); the runs' statuses, and how many
ended `complete` with a goal missed.

Usage: python bench/budget_coverage.py FOLDER [FOLDER ...] [--quantile 0.95]
                                       [--k-target K --k-rms K]

With --k-target and --k-rms the runs that ran their program are decided again with those
factors (`complete` or `at_risk`, as the job would have with them in `verify.budget`).

Each FOLDER is a campaign (`twincell campaign skull --stage full --trials 60 --seed 76000
--workers 2 --out FOLDER`: its results.csv) or a folder of run folders (every results.json
below it). The coverage factors are calibrated on one set of seeds and checked on another:
docs/concepts/faults.md gives both.
"""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Run:
    """One run: its status, its targets' true errors and budget sigmas [m], its target RMS,
    the coverage factors and goals its budget used, whether it met its goals."""

    status: str
    errors_m: tuple[float, ...]
    sigmas_m: tuple[float, ...]
    k_target: float
    k_rms: float
    goal_rms_m: float | None
    goal_max_m: float | None

    @property
    def rms_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.errors_m))))

    @property
    def rms_sigma_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.sigmas_m))))

    def decided(self, k_target: float, k_rms: float) -> Run:
        """The run as its budget decides it with other coverage factors."""
        if self.status not in ("complete", "at_risk"):
            return replace(self, k_target=k_target, k_rms=k_rms)
        worst = k_target * max(self.sigmas_m)
        risk = (self.goal_rms_m is not None and k_rms * self.rms_sigma_m > self.goal_rms_m) or (
            self.goal_max_m is not None and worst > self.goal_max_m
        )
        status = "at_risk" if risk else "complete"
        return replace(self, status=status, k_target=k_target, k_rms=k_rms)

    @property
    def missed(self) -> bool:
        rms, worst = self.rms_m, max(self.errors_m)
        return (self.goal_rms_m is not None and rms > self.goal_rms_m) or (
            self.goal_max_m is not None and worst > self.goal_max_m
        )


def from_results(path: Path) -> Run | None:
    """A run from its results.json (None: no budget, or no target reached)."""
    data = json.loads(path.read_text())
    budget = data.get("budget")
    if not budget or not data.get("targets"):
        return None
    sigma = {t["name"]: t["sigma_m"] for t in budget["targets"]}
    targets = [t for t in data["targets"] if t["name"] in sigma]
    return Run(
        data["status"],
        tuple(float(t["error_m"]) for t in targets),
        tuple(float(sigma[t["name"]]) for t in targets),
        float(budget["k_target"]),
        float(budget["k_rms"]),
        budget["goal_rms_m"],
        budget["goal_max_m"],
    )


def from_campaign(path: Path) -> list[Run]:
    """The runs of a campaign's results.csv that have a budget (k and goals from the job's
    defaults, as the rows do not hold them)."""
    from scenarios.offline.settings import PlanningSettings

    settings = PlanningSettings()
    out = []
    with open(path / "results.csv", newline="") as handle:
        for row in csv.DictReader(handle):
            if not row.get("budget_rms_bound_m"):
                continue
            errors, sigmas = [], []
            for k in range(int(row["n_targets"] or 0)):
                e, s = row.get(f"exec_err_t{k}_m"), row.get(f"budget_sigma_t{k}_m")
                if e and s:
                    errors.append(float(e))
                    sigmas.append(float(s))
            if errors:
                budget = settings.verify.budget
                out.append(
                    Run(row["run_status"], tuple(errors), tuple(sigmas), budget.k_target,
                        budget.k_rms, settings.goal_rms_m, settings.goal_max_m)
                )  # fmt: skip
    return out


def runs_in(folder: Path) -> list[Run]:
    if (folder / "results.csv").is_file():
        return from_campaign(folder)
    found = (from_results(p) for p in sorted(folder.rglob("results.json")))
    return [r for r in found if r is not None]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--quantile", type=float, default=0.95)
    parser.add_argument("--k-target", type=float)
    parser.add_argument("--k-rms", type=float)
    args = parser.parse_args()
    runs = [r for folder in args.folders for r in runs_in(folder)]
    if (args.k_target is None) != (args.k_rms is None):
        raise SystemExit("give both --k-target and --k-rms, or neither")
    if args.k_target is not None:
        runs = [r.decided(args.k_target, args.k_rms) for r in runs]
    if not runs:
        raise SystemExit(f"no run with an error budget in {', '.join(map(str, args.folders))}")
    ratios = np.concatenate([np.divide(r.errors_m, r.sigmas_m) for r in runs])
    rms_ratios = np.array([r.rms_m / r.rms_sigma_m for r in runs])
    targets = sum(len(r.errors_m) for r in runs)
    covered = sum(
        int(e <= r.k_target * s) for r in runs for e, s in zip(r.errors_m, r.sigmas_m, strict=True)
    )
    rms_covered = sum(int(r.rms_m <= r.k_rms * r.rms_sigma_m) for r in runs)
    statuses = {s: sum(r.status == s for r in runs) for s in sorted({r.status for r in runs})}
    claimed = sum(r.status == "complete" and r.missed for r in runs)
    print(f"runs {len(runs)}, targets {targets}; statuses {statuses}")
    print(f"coverage factors used: k_target {runs[0].k_target:g}, k_rms {runs[0].k_rms:g}")
    print(f"targets within their bound: {covered} of {targets} ({covered / targets:.1%})")
    print(f"runs' RMS within the RMS bound: {rms_covered} of {len(runs)} "
          f"({rms_covered / len(runs):.1%})")  # fmt: skip
    print(f"runs complete with a goal missed: {claimed}; runs at risk that met their goals: "
          f"{sum(r.status == 'at_risk' and not r.missed for r in runs)}")  # fmt: skip
    q = args.quantile
    print(f"factors covering {q:.0%}: k_target {np.quantile(ratios, q):.3f}, "
          f"k_rms {np.quantile(rms_ratios, q):.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
