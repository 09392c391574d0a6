"""`twincell register` as a command: wall time against the match's own time, before and after
the fast register path (lazy imports, numpy readers, prepared models, batches).

The case: a real single range view of the Stanford dragon (tests/data/stanford/dragon,
scan_stand000: 35,000 points, the largest shipped view) against the dragon's reconstructed
mesh (34,636 vertices, 70,214 faces): the shipped pair closest to a 40,000-point scan against
a 35,000-vertex mesh. The scan is given as the shipped binary PLY, as an ascii PLY and as an
xyz text file (written once into a temporary folder); the model as its PLY file or as a
prepared model (.twm, written by `twincell prepare`).

Forms, each timed as a fresh process (the same launcher for all: `python -c "from
scenarios.cli import main; ..."`), best of --repeats:
- before: `register SCAN model.ply` run by the code of --before (default: the last commit
  before the fast path), exported with `git archive` into a temporary folder;
- one scan: `register SCAN model.ply` run by this checkout;
- .twm: `register SCAN model.twm`;
- batch: `register SCAN x5 model.twm` (the same scan five times, so that a line compares
  with one call): its wall time and match time per scan.
"wall" is the command's wall time, "match" its `seconds` (the match inside `match()`; with a
model file it includes building the model's structures, which `match` does on its first call
with a model; with a .twm they were built by `prepare`), "overhead" the difference: starting
Python, imports, reading the files, writing the output.

Usage: python bench/bench_register_cli.py [--repeats 5] [--before REF] [--short]
--short runs one case once (the .twm form on the xyz file) and checks its output.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "stanford" / "dragon"
SCAN = DATA / "scan_stand000.ply"
MODEL = DATA / "model.ply"
#: The last commit before the fast register path: what "before" runs.
BASELINE = "76126ff"
LAUNCH = "import sys; from scenarios.cli import main; sys.exit(main(sys.argv[1:]))"
BATCH = 5


@dataclass(frozen=True)
class Timing:
    """One form on one input: the best wall time [s] of the runs and its match time [s] (per
    scan for a batch)."""

    form: str
    input: str
    wall: float
    match: float

    @property
    def overhead(self) -> float:
        return self.wall - self.match


def run(code: Path, args: list[str]) -> float:
    """The wall time [s] of one `twincell` call run by the code in `code`."""
    env = dict(os.environ, PYTHONPATH=str(code))
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", LAUNCH, *args], env=env, capture_output=True, text=True
    )
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"twincell {' '.join(args)} failed: {done.stderr.strip()}")
    return wall


def seconds_of(out: Path) -> list[float]:
    """The match seconds of a --json result file, or of each line of a batch's file."""
    text = out.read_text()
    try:
        return [float(json.loads(text)["seconds"])]
    except json.JSONDecodeError:
        return [float(json.loads(line)["seconds"]) for line in text.splitlines()]


def best_of(code: Path, args: list[str], out: Path, repeats: int, per: int = 1) -> tuple:
    """The best wall time of `repeats` runs and the mean match seconds of that run, both per
    scan (`per` scans in a call)."""
    best = (float("inf"), 0.0)
    for _ in range(repeats):
        wall = run(code, [*args, "--json", str(out)])
        if wall < best[0]:
            best = (wall, statistics.fmean(seconds_of(out)))
    return best[0] / per, best[1]


def inputs(folder: Path) -> dict[str, Path]:
    """The scan as the shipped binary PLY, as an ascii PLY and as an xyz file."""
    from registration.io.mesh import read_mesh

    points, _ = read_mesh(SCAN, points_only=True)
    xyz = folder / "scan.xyz"
    np.savetxt(xyz, points, fmt="%.9g")  # the float32 values, exactly
    ascii_ply = folder / "scan_ascii.ply"
    header = (
        f"ply\nformat ascii 1.0\nelement vertex {len(points)}\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n"
    )
    with ascii_ply.open("w") as f:
        f.write(header)
        np.savetxt(f, points, fmt="%.9g")
    return {"xyz": xyz, "PLY (binary)": SCAN, "PLY (ascii)": ascii_ply}


def export(ref: str, folder: Path) -> Path:
    """The packages of commit `ref`, exported into `folder` (git archive: the repository's
    worktrees and index are left alone)."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", ref, "registration", "scenarios", "cell", "models"],
        capture_output=True,
        check=True,
    )
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder


def measure(args: argparse.Namespace, folder: Path) -> list[Timing]:
    files = inputs(folder)
    twm = folder / "model.twm"
    run(ROOT, ["prepare", str(MODEL), "--out", str(twm)])
    out = folder / "out.json"
    before = None if args.before == "none" else export(args.before, folder / "before")
    rows: list[Timing] = []
    for name, scan in files.items():
        forms = [("one scan, model.ply", [str(scan), str(MODEL)], ROOT, 1)]
        if before is not None:
            forms.insert(0, ("before, model.ply", [str(scan), str(MODEL)], before, 1))
        forms += [
            ("one scan, model.twm", [str(scan), str(twm)], ROOT, 1),
            (f"batch of {BATCH}, model.twm, per scan", [str(scan)] * BATCH + [str(twm)], ROOT,
             BATCH),
        ]  # fmt: skip
        for form, call, code, per in forms:
            wall, match = best_of(code, ["register", *call], out, args.repeats, per)
            rows.append(Timing(form, name, wall, match))
            print(f"  {name:13s} {form:38s} wall {wall:.3f} s, match {match:.3f} s", flush=True)
    return rows


def table(rows: list[Timing]) -> str:
    lines = [
        "| input | form | wall s | match s | overhead s |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r.input} | {r.form} | {r.wall:.3f} | {r.match:.3f} | {r.overhead:.3f} |")
    return "\n".join(lines)


def short(folder: Path) -> None:
    """One case, once: the .twm form on the xyz file; its output must be a result."""
    files = inputs(folder)
    twm = folder / "model.twm"
    run(ROOT, ["prepare", str(MODEL), "--out", str(twm)])
    out = folder / "out.json"
    wall = run(ROOT, ["register", str(files["xyz"]), str(twm), "--json", str(out)])
    result = json.loads(out.read_text())
    assert result["verdict"] == "accepted", result["verdict"]
    match = float(result["seconds"])
    print(table([Timing("one scan, model.twm", "xyz", wall, match)]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs per case (best taken)")
    parser.add_argument(
        "--before", default=BASELINE, help="commit whose code is 'before' (none: skip it)"
    )
    parser.add_argument("--short", action="store_true", help="one case, once")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.short:
            short(Path(tmp))
            return
        print(
            f"dragon scan_stand000 (35,000 points) against the dragon mesh (34,636 vertices); "
            f"best of {args.repeats}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}",
            flush=True,
        )
        rows = measure(args, Path(tmp))
    print()
    print(table(rows))


if __name__ == "__main__":
    main()
