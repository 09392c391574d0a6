"""The skull job on the point laser's cell against the line laser's, seed by seed.

    python bench/bench_point_laser.py [--seeds 400 401 ...] [--lasers point line] [--jobs 2]
        [--out DIR]

For each seed: `twincell run skull --seed S --cell point_laser` (the seed paper's analog
distance sensor: one ray, its passes rasters of lines, the calibration at stops across the
spheres) and `twincell run skull --seed S` (the line profiler), each in a process of its own,
`--jobs` at a time. Prints each run's status, target errors (the evaluator's, against the
truth), the arm's true TCP error after the calibration, the scan's passes and cell time, and
the job's cell time; then the goals met per laser.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from rich.console import Console
from rich.table import Table

LASERS = {"point": ("--cell", "point_laser"), "line": ()}


def _run(seed: int, laser: str, out: Path) -> dict:
    """The results of `twincell run skull --seed SEED` with `laser`'s cell."""
    folder = out / f"{laser}-{seed}"
    command = [sys.executable, "-m", "scenarios.cli", "run", "skull", "--seed", str(seed)]
    command += [*LASERS[laser], "--out", str(folder), "--no-rrd", "--quiet"]
    subprocess.run(command, capture_output=True, check=False)
    found = list(folder.glob("skull-*/results.json"))
    return json.loads(found[0].read_text()) if found else {"status": "no results"}


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.3f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[400, 401, 402, 403, 404])
    parser.add_argument("--lasers", nargs="+", choices=list(LASERS), default=list(LASERS))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="twincell-point-laser-"))
    runs = [(seed, laser) for seed in args.seeds for laser in args.lasers]
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda run: _run(*run, out), runs))
    table = Table(title="the skull job: point laser against line laser")
    for header in ("seed", "laser", "status", "target RMS / max [mm]", "TCP calibrated [mm]",
                   "passes", "scan [s]", "cell time [s]"):  # fmt: skip
        table.add_column(header)
    met = dict.fromkeys(args.lasers, 0)
    for (seed, laser), r in zip(runs, results, strict=True):
        plan = r.get("scan_plan") or {}
        calibration = r.get("calibration") or {}
        met[laser] += r.get("status") == "complete"
        table.add_row(
            str(seed), laser, str(r.get("status")),
            f"{_mm(r.get('target_error_rms_m'))} / {_mm(r.get('target_error_max_m'))}",
            _mm(calibration.get("tcp_error_calibrated_mean_m")), str(plan.get("passes", "-")),
            f"{plan.get('scan_time_s') or 0.0:.0f}", f"{r.get('cell_time_s') or 0.0:.0f}",
        )  # fmt: skip
    console = Console(width=160)
    console.print(table)
    for laser, n in met.items():
        console.print(f"{laser} laser: {n} of {len(args.seeds)} runs complete within their goals")
    return 0


if __name__ == "__main__":
    sys.exit(main())
