"""Campaign throughput: the same register-stage trials on each backend, one table.

    python bench/bench_campaign.py [--trials 20]

Rows: the local backend in this process (1 worker), with 2 worker processes, and a local
Dask cluster of 2 workers (start-up included). Every backend runs the same seeded trials
into a fresh folder; the rows it stores are checked to be the same (timings aside).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from scenarios.campaign import plan_campaign, run_campaign

TIMING = ("match_seconds", "trial_seconds")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    args = parser.parse_args()
    spec = plan_campaign("skull", stage="register", trials=args.trials)
    results = []
    reference = None
    for backend, workers in (("local", 1), ("local", 2), ("dask", 2)):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            outcome = run_campaign(spec, Path(tmp) / "c", backend, workers, progress=False)
            seconds = time.perf_counter() - t0
        rows = [{k: v for k, v in r.items() if k not in TIMING} for r in outcome.rows]
        reference = reference or rows
        same = rows == reference
        results.append((backend, workers, outcome.ran, seconds, outcome.ran / seconds, same))
    print(f"{'backend':8} {'workers':>7} {'trials':>6} {'wall [s]':>9} {'trials/s':>9}  same rows")
    for backend, workers, ran, seconds, rate, same in results:
        print(f"{backend:8} {workers:>7} {ran:>6} {seconds:>9.1f} {rate:>9.2f}  {same}")


if __name__ == "__main__":
    main()
