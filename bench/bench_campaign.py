"""Campaign throughput: the same seeded trials on each backend, and before vs after.

    python bench/bench_campaign.py [--trials 20] [--full-trials 6] [--repeats 2]
                                   [--before 67e7472] [--after COMMIT]
                                   [--only backends|versions] [--no-cache] [--short]

1. Backends: the same register-stage trials of the skull in this process (1 worker), on 2
   worker processes and on a local Dask cluster of 2 workers (start-up included); the rows
   each stores are checked to be the same (timings aside).
2. Versions: register-stage and full-stage trials per minute on 2 worker processes (the local
   backend), before (the code at --before: a commit, exported with `git archive` into a
   temporary folder, or a folder holding a checkout) and after (this checkout as it is, or
   the code at --after, a commit or a folder likewise). Each campaign runs in a fresh process
   whose PYTHONPATH puts its version first; the same seeded trials, on the same machine, in
   the same run, the order of the versions alternating from repeat to repeat. The time is
   run_campaign's (worker start-up, the models, the trials, the report), not the
   interpreter's start; "CPU" is the user + system time of the campaign's process and its
   workers, which a loaded machine changes less. Each version's rows are compared with the
   after's (timings aside). Both read and fill the user's model cache as they find it (the
   before of 67e7472 has none); --no-cache turns it off for both.

--short: 2 register trials per backend, 2 register-stage trials per version (no full-stage
trial), one repeat; a --before commit missing from this clone (a shallow one) is noted and
its rows left out.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("cell", "models", "registration", "scenarios")
WORKERS = 2
BEFORE = "67e7472"


def _timing(key: str) -> bool:
    """Whether a row's column is a wall time (match_seconds, trial_seconds, <stage>_seconds)."""
    return key.endswith("seconds")


def _untimed(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if not _timing(k)} for r in rows]


def backends_table(trials: int) -> None:
    """The register stage's trials on each backend: one table."""
    from scenarios.campaign import plan_campaign, run_campaign

    spec = plan_campaign("skull", stage="register", trials=trials)
    results = []
    reference = None
    for backend, workers in (("local", 1), ("local", WORKERS), ("dask", WORKERS)):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            outcome = run_campaign(spec, Path(tmp) / "c", backend, workers, progress=False)
            seconds = time.perf_counter() - t0
        rows = _untimed(outcome.rows)
        reference = reference or rows
        same = rows == reference
        results.append((backend, workers, outcome.ran, seconds, outcome.ran / seconds, same))
    print(f"{'backend':8} {'workers':>7} {'trials':>6} {'wall [s]':>9} {'trials/s':>9}  same rows")
    for backend, workers, ran, seconds, rate, same in results:
        print(f"{backend:8} {workers:>7} {ran:>6} {seconds:>9.1f} {rate:>9.2f}  {same}")


def _cpu_seconds() -> float:
    """User + system time [s] of this process and its finished children."""
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                     resource.RUSAGE_CHILDREN))  # fmt: skip
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def child(stage: str, trials: int, out: Path) -> None:
    """One campaign of the skull on WORKERS processes, with the code on PYTHONPATH; prints
    one JSON line: trials run, seconds, CPU seconds (the workers' included: the pool has
    ended), the rows, and where the code came from."""
    import scenarios
    from scenarios.campaign import plan_campaign, run_campaign

    spec = plan_campaign("skull", stage=stage, trials=trials)
    t0, cpu0 = time.perf_counter(), _cpu_seconds()
    outcome = run_campaign(spec, out, "local", WORKERS, progress=False)
    seconds, cpu = time.perf_counter() - t0, _cpu_seconds() - cpu0
    found = {"ran": outcome.ran, "seconds": seconds, "cpu": cpu, "rows": outcome.rows,
             "code": str(Path(scenarios.__file__).resolve().parent.parent)}  # fmt: skip
    print(json.dumps(found, default=str))


def export(rev: str, into: Path) -> Path | None:
    """The packages at commit `rev` of this clone, written into `into`; None if the clone does
    not hold `rev`."""
    done = subprocess.run(
        ["git", "-C", str(ROOT), "archive", "--format=tar", rev, *PACKAGES],
        capture_output=True,
    )  # fmt: skip
    if done.returncode != 0:
        return None
    with tarfile.open(fileobj=io.BytesIO(done.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def run_version(code: Path, stage: str, trials: int, out: Path, no_cache: bool) -> dict[str, Any]:
    """A campaign in a fresh process with `code` first on its PYTHONPATH."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(code), *filter(None, [env.get("PYTHONPATH")])])
    if no_cache:
        env["TWINCELL_NO_CACHE"] = "1"
    command = [sys.executable, __file__, "--child", stage, str(trials), str(out)]
    done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=out.parent)
    if done.returncode != 0:
        raise RuntimeError(f"the {stage} campaign with {code} failed:\n{done.stderr[-3000:]}")
    found = json.loads(done.stdout.strip().splitlines()[-1])
    if Path(found["code"]) != code.resolve():
        raise RuntimeError(f"the campaign ran the code in {found['code']}, not {code}")
    return found


def _differing(rows: list[dict[str, Any]], reference: list[dict[str, Any]]) -> str:
    """Which columns (present in both, timings aside) differ between two campaigns' rows."""
    if len(rows) != len(reference):
        return f"{len(rows)} rows, not {len(reference)}"
    keys = set()
    for a, b in zip(_untimed(rows), _untimed(reference), strict=True):
        keys |= {k for k in a.keys() & b.keys() if a[k] != b[k]}
    return "same" if not keys else "differ: " + ", ".join(sorted(keys))


def _code(where: str, into: Path) -> Path | None:
    """The code of a version: a folder as it is, or a commit exported into `into`."""
    return Path(where) if Path(where).is_dir() else export(where, into)


def versions_table(args: argparse.Namespace) -> None:
    """Register- and full-stage trials per minute, before and after: one table."""
    stages = tuple(
        (stage, n) for stage, n in (("register", args.trials), ("full", args.full_trials)) if n > 0
    )
    with tempfile.TemporaryDirectory(prefix="twincell-thru-") as tmp:
        before = _code(args.before, Path(tmp) / "before")
        if before is None:
            if not args.short:
                sys.exit(f"commit {args.before} is not in this clone: give --before a checkout")
            print(f"note: commit {args.before} is not in this clone: before left out")
        after = ROOT if args.after is None else _code(args.after, Path(tmp) / "after")
        if after is None:
            sys.exit(f"commit {args.after} is not in this clone")
        versions = ({"before": before} if before is not None else {}) | {"after": after}
        found: list[tuple[str, str, int, dict[str, Any]]] = []
        for repeat in range(args.repeats):
            order = list(versions) if repeat % 2 == 0 else list(reversed(versions))
            for stage, trials in stages:
                for version in order:
                    out = Path(tmp) / f"{stage}-{version}-{repeat}"
                    result = run_version(versions[version], stage, trials, out, args.no_cache)
                    found.append((stage, version, repeat, result))
    print(
        f"skull campaigns on {WORKERS} worker processes; before: {args.before}, after: "
        f"{args.after or 'this checkout'}; model cache {'off' if args.no_cache else 'as found'}"
    )
    print(f"{'stage':9} {'version':7} {'repeat':>6} {'trials':>6} {'seconds':>8} "
          f"{'trials/min':>10} {'CPU s/trial':>11}  rows vs after's")  # fmt: skip
    after_rows = {(s, r): res["rows"] for s, v, r, res in found if v == "after"}
    rates: dict[tuple[str, str], list[float]] = {}
    cpus: dict[tuple[str, str], list[float]] = {}
    for stage, version, repeat, result in found:
        rate = 60.0 * result["ran"] / result["seconds"]
        rates.setdefault((stage, version), []).append(rate)
        same = _differing(result["rows"], after_rows[(stage, repeat)])
        cpu = result["cpu"] / result["ran"]
        cpus.setdefault((stage, version), []).append(cpu)
        print(f"{stage:9} {version:7} {repeat + 1:>6} {result['ran']:>6} "
              f"{result['seconds']:>8.1f} {rate:>10.2f} {cpu:>11.1f}  {same}")  # fmt: skip
    versions_order = ("after", "before")
    for stage, _ in stages:
        if (stage, "before") in rates:
            after, before_rate = (statistics.median(rates[(stage, v)]) for v in versions_order)
            cpu_after, cpu_before = (statistics.median(cpus[(stage, v)]) for v in versions_order)
            print(f"{stage}: trials/min after / before = {after / before_rate:.2f} (medians "
                  f"{after:.2f} vs {before_rate:.2f}); CPU s/trial {cpu_after:.1f} vs "
                  f"{cpu_before:.1f}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20, help="register-stage trials")
    parser.add_argument("--full-trials", type=int, default=6, help="full-stage trials")
    parser.add_argument("--repeats", type=int, default=2, help="of the versions' campaigns")
    parser.add_argument("--before", default=BEFORE, help="a commit, or a checkout's folder")
    parser.add_argument("--after", default=None, help="default: this checkout as it is")
    parser.add_argument("--only", choices=("backends", "versions"), default=None)
    parser.add_argument("--no-cache", action="store_true", help="TWINCELL_NO_CACHE=1 for both")
    parser.add_argument("--short", action="store_true", help="the fewest trials, one repeat")
    parser.add_argument("--child", nargs=3, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], int(args.child[1]), Path(args.child[2]))
        return
    if args.short:
        args.trials, args.full_trials, args.repeats = 2, 0, 1
    if args.only in (None, "backends"):
        backends_table(args.trials)
    if args.only is None:
        print()
    if args.only in (None, "versions"):
        versions_table(args)


if __name__ == "__main__":
    main()
