"""Whether a change of the code leaves every figure of a run as it was: a fixed set of varied
runs (both arms, both jobs, the paper, faults, calibration off), made once with each
checkout, and their results.json compared key by key, timings aside.

    # with the checkout before the change on PYTHONPATH, then with the one after
    PYTHONPATH=/path/to/before python bench/same_figures.py run /tmp/before
    PYTHONPATH=/path/to/after  python bench/same_figures.py run /tmp/after
    python bench/same_figures.py compare /tmp/before /tmp/after

`compare` prints a table of the runs (keys compared, keys that differ) and every key that
differs (exit status 1 if any does). Keys that hold wall-clock time, the run's folder or the
code's version are not figures and are left out (`IGNORED`). Runs take about a minute each;
`--jobs 2` runs two at a time. `--short` makes the paper's run twice with the checkout on the
path and compares the two (a run is the same when made again: what the comparison rests on).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

#: name -> arguments of `twincell run`
RUNS: dict[str, list[str]] = {
    "skull-0": ["skull", "--seed", "0"],
    "skull-5": ["skull", "--seed", "5"],
    "skull-ur5-2": ["skull", "--cell", "ur5", "--seed", "2"],
    "skull-ur5-7": ["skull", "--cell", "ur5", "--seed", "7"],
    "assembly-0": ["assembly", "--seed", "0"],
    "assembly-3": ["assembly", "--seed", "3"],
    "paper-0": ["paper", "--seed", "0"],
    "skull-seat-95014": ["skull", "--seed", "95014", "--fault", "tool_lock_fail=0.0001"],
    "skull-bump-1": ["skull", "--seed", "1", "--fault", "object_bump"],
    "skull-spurious-3": ["skull", "--seed", "3", "--fault", "laser_spurious"],
    "skull-uncalibrated-4": ["skull", "--seed", "4", "--set", "calibration.enabled=false"],
}
#: Keys (at any depth) that are not figures of the run.
IGNORED = {
    "timings_s", "wall_s", "elapsed_s", "seconds", "t_total_s", "created", "started",
    "finished", "version", "folder", "run_folder", "path", "source", "code_version",
}  # fmt: skip


def run(out: Path, jobs: int, names: list[str]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, TWINCELL_NO_CACHE="1")

    def one(name: str) -> str:
        folder = out / name
        command = [sys.executable, "-m", "scenarios.cli.app", "run", *RUNS[name],
                   "--out", str(folder), "--no-rrd", "--quiet"]  # fmt: skip
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        return f"{name}: exit {done.returncode}"

    with ThreadPoolExecutor(jobs) as pool:
        for line in pool.map(one, names):
            print(line, flush=True)


def _results(folder: Path) -> dict[str, Any]:
    found = sorted(folder.glob("**/results.json"))
    if not found:
        raise SystemExit(f"no results.json under {folder}")
    return dict(json.loads(found[-1].read_text()))


def _leaves(a: Any) -> int:
    if isinstance(a, dict):
        return sum(_leaves(v) for k, v in a.items() if k not in IGNORED)
    if isinstance(a, list):
        return sum(_leaves(v) for v in a)
    return 1


def _differences(a: Any, b: Any, where: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b)):
            if key in IGNORED:
                continue
            if key not in a or key not in b:
                out.append(f"{where}.{key}: only in {'after' if key not in a else 'before'}")
                continue
            out += _differences(a[key], b[key], f"{where}.{key}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items before, {len(b)} after"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in _differences(x, y, f"{where}[{i}]")]  # fmt: skip
    if isinstance(a, float) and isinstance(b, float):
        same = a == b or (math.isnan(a) and math.isnan(b))
        return [] if same else [f"{where}: {a!r} before, {b!r} after"]
    return [] if a == b else [f"{where}: {a!r} before, {b!r} after"]


def compare(before: Path, after: Path, names: list[str]) -> int:
    print("| run | keys compared | keys that differ |\n|---|---:|---:|")
    found = {}
    for name in names:
        a, b = _results(before / name), _results(after / name)
        found[name] = _differences(a, b)
        print(f"| {name} | {_leaves(a)} | {len(found[name])} |")
    for name, diffs in found.items():
        for d in diffs[:20]:
            print(f"{name}: {d}")
    return 1 if any(found.values()) else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="make the runs into a folder")
    r.add_argument("out", type=Path)
    r.add_argument("--jobs", type=int, default=1)
    c = sub.add_parser("compare", help="compare two folders of runs key by key")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    s = sub.add_parser("short", help="the paper's run made twice and compared")
    s.add_argument("--out", type=Path, default=None)
    short = sys.argv[1:2] == ["--short"]
    args = parser.parse_args(["short", *sys.argv[2:]] if short else None)
    if args.command == "run":
        run(args.out, args.jobs, list(RUNS))
        return 0
    if args.command == "compare":
        return compare(args.before, args.after, list(RUNS))
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        run(out / "first", 1, ["paper-0"])
        run(out / "again", 1, ["paper-0"])
        return compare(out / "first", out / "again", ["paper-0"])


if __name__ == "__main__":
    sys.exit(main())
