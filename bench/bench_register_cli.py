"""`twincell register` as a command: wall time against the match's own time, before and after
the fast register path (lazy imports, numpy readers, prepared models, batches).

The case: a real single range view of the Stanford dragon (tests/data/stanford/dragon,
scan_stand000: 35,000 points, the largest shipped view) against the dragon's reconstructed
mesh (34,636 vertices, 70,214 faces): the shipped pair closest to a 40,000-point scan against
a 35,000-vertex mesh. The scan is given as the shipped binary PLY, as an xyz text file, as an
ascii PLY of its points, as an ascii PLY as a range scanner writes one (normals, a
confidence, an intensity and the triangles between neighbouring points), and as a
Cyberware range image as the Stanford 3D Scanning Repository keeps its scans (the points,
then a `range_grid` element of one list per grid cell), written once into a temporary
folder; the model as its PLY file or as a prepared model (.twm, written by
`twincell prepare`).

Forms, each timed as a fresh process (the same launcher for all: `python -c "from
scenarios.cli import main; ..."`), best of --repeats, the cases taken in turn within each
repeat so that on a loaded machine they share its ups and downs:
- before: `register SCAN model.ply` run by the code of --before (default: the last commit
  before the fast path), exported with `git archive` into a temporary folder;
- one scan: `register SCAN model.ply` run by this checkout;
- .twm: `register SCAN model.twm`;
- batch: `register SCAN x5 model.twm` (the same scan five times, so that a line compares
  with one call): its times per scan;
- and, for reference, the imports that any register call needs, alone: numpy, scipy.spatial
  and libigl, then also typer (with the pydantic it imports to parse options) and rich (the
  table).
"wall" is the command's wall time, "match" its `seconds` (the time inside `match()`; with a
model file it includes building the model's structures, which `match` does on its first call
with a model; with a .twm they were built by `prepare`), "overhead" the difference: starting
Python, imports, reading the files, writing the output; "CPU" the command's user + system
time (all threads: the match's KD-tree queries use both cores).

Usage: python bench/bench_register_cli.py [--repeats 5] [--before REF] [--short]
--short runs one case (the .twm form on the xyz file, twice) and checks its output.
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
#: Where the timed calls keep their compiled bytecode (out of the checkout).
PYCACHE = Path(tempfile.gettempdir()) / "twincell-bench-pycache"
BATCH = 5


@dataclass(frozen=True)
class Case:
    """One form on one input: the code that runs it, the command's arguments, and how many
    scans one call registers."""

    input: str
    form: str
    code: Path
    args: tuple[str, ...]
    scans: int = 1


@dataclass(frozen=True)
class Timing:
    """A case's best run (least wall time) per scan: wall and CPU time of the command [s]
    and the match's own `seconds` (mean over a batch's scans)."""

    case: Case
    wall: float
    cpu: float
    match: float

    @property
    def overhead(self) -> float:
        return self.wall - self.match


def run(code: Path, args: list[str] | tuple[str, ...]) -> tuple[float, float]:
    """Wall and CPU time [s] (user + system, all threads) of one call of the code in `code`:
    `twincell ARGS`, or a Python statement if ARGS is ("-c", STATEMENT).

    The compiled bytecode is cached between calls, as an installed package has it, in a
    folder of its own (PYCACHE), even where PYTHONDONTWRITEBYTECODE is set: the first call
    compiles, the others do not.
    """
    env = dict(os.environ, PYTHONPATH=str(code), PYTHONPYCACHEPREFIX=str(PYCACHE))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    command = [sys.executable, *args] if args[0] == "-c" else [sys.executable, "-c", LAUNCH, *args]
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        # Not from the checkout: Python puts the working directory before PYTHONPATH.
        process = subprocess.Popen(
            command, env=env, cwd=tempfile.gettempdir(), stdout=subprocess.DEVNULL, stderr=err
        )
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - t0
        process.returncode = os.waitstatus_to_exitcode(status)
        if process.returncode != 0:
            err.seek(0)
            raise RuntimeError(f"{' '.join(args)} failed: {err.read().decode().strip()}")
    return wall, usage.ru_utime + usage.ru_stime


def seconds_of(out: Path) -> list[float]:
    """The match seconds of a --json result file, or of each line of a batch's file."""
    text = out.read_text()
    try:
        return [float(json.loads(text)["seconds"])]
    except json.JSONDecodeError:
        return [float(json.loads(line)["seconds"]) for line in text.splitlines()]


def timings(cases: list[Case], out: Path, repeats: int) -> list[Timing]:
    """Each case's best of `repeats` runs, the cases taken in turn within each repeat (on a
    loaded machine they then share its ups and downs)."""
    best: dict[Case, Timing] = {}
    for k in range(repeats):
        for case in cases:
            measured = case.args[0] != "-c"
            args = [*case.args, "--json", str(out)] if measured else list(case.args)
            wall, cpu = run(case.code, args)
            match = statistics.fmean(seconds_of(out)) if measured else 0.0
            n = case.scans
            if case not in best or wall / n < best[case].wall:
                best[case] = Timing(case, wall / n, cpu / n, match)
        print(f"  repeat {k + 1} of {repeats} done", flush=True)
    return [best[case] for case in cases]


def inputs(folder: Path) -> dict[str, Path]:
    """The scan as the shipped binary PLY, as an xyz file, as an ascii PLY of its points,
    and as an ascii PLY as range scanners write one: per vertex its normal, a confidence
    and an intensity, and the triangles between neighbouring points (a Delaunay
    triangulation of the points seen along the scanner's z axis)."""
    from scipy.spatial import Delaunay

    from registration.io.mesh_files import read_mesh

    points, _ = read_mesh(SCAN, points_only=True)
    xyz = write_xyz(folder, points)
    ascii_ply = folder / "scan_ascii.ply"
    _write_ascii_ply(ascii_ply, points)
    scanner_ply = folder / "scan_scanner.ply"
    triangles = Delaunay(points[:, :2]).simplices
    rng = np.random.default_rng(0)
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    extra = np.c_[normals, rng.uniform(0.5, 1.0, len(points)), rng.integers(0, 255, len(points))]
    _write_ascii_ply(scanner_ply, points, extra, triangles)
    grid_ply = folder / "scan_range_grid.ply"
    _write_range_grid(grid_ply, points)
    return {
        "xyz": xyz,
        "PLY (binary)": SCAN,
        "PLY (ascii)": ascii_ply,
        "PLY (ascii, scanner's)": scanner_ply,
        "PLY (ascii, range grid)": grid_ply,
    }


def _write_range_grid(path: Path, points: np.ndarray, columns: int = 512) -> None:
    """The points (N, 3) as a Cyberware range image's PLY (the Stanford bunny's bun000.ply):
    the vertices, then a `range_grid` of `columns` times as many rows as the points need,
    each cell "0" (nothing seen) or "1 INDEX", the points spread over the cells in order."""
    cells = columns * int(np.ceil(5 * len(points) / columns))
    seen = np.full(cells, -1)
    seen[np.linspace(0, cells - 1, len(points)).astype(int)] = np.arange(len(points))
    header = (
        f"ply\nformat ascii 1.0\nobj_info num_cols {columns}\n"
        f"obj_info num_rows {cells // columns}\nelement vertex {len(points)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element range_grid {cells}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with path.open("w") as f:
        f.write(header)
        np.savetxt(f, points, fmt="%.9g")
        f.write("\n".join("0" if i < 0 else f"1 {i}" for i in seen) + "\n")


def write_xyz(folder: Path, points: np.ndarray) -> Path:
    """The points (N, 3) as folder/scan.xyz, 9 digits: the float32 values to their
    precision."""
    xyz = folder / "scan.xyz"
    np.savetxt(xyz, points, fmt="%.9g")
    return xyz


def _write_ascii_ply(
    path: Path, points: np.ndarray, extra: np.ndarray | None = None, faces: np.ndarray | None = None
) -> None:
    """An ascii PLY of points (N, 3), with extra vertex columns (nx, ny, nz, confidence,
    intensity) and triangles (F, 3) if given."""
    props = "property float x\nproperty float y\nproperty float z\n"
    columns, fmt = points, ["%.9g"] * 3
    if extra is not None:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
        props += "property float confidence\nproperty uchar intensity\n"
        columns, fmt = np.c_[points, extra], fmt + ["%.6g"] * 4 + ["%d"]
    header = f"ply\nformat ascii 1.0\nelement vertex {len(points)}\n{props}"
    if faces is not None:
        header += f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
    with path.open("w") as f:
        f.write(header + "end_header\n")
        np.savetxt(f, columns, fmt=fmt)
        if faces is not None:
            np.savetxt(f, np.c_[np.full(len(faces), 3), faces], fmt="%d")


def export(ref: str, folder: Path) -> Path:
    """The packages of commit `ref`, exported into `folder` (git archive: the repository's
    worktrees and index are left alone)."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", ref, "registration", "scenarios", "cell", "models"],
        capture_output=True,
        check=True,
    )
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder


#: The imports any register call needs, whatever the code around them: the numerical ones,
#: then with the command line's (typer, with the pydantic it parses options with, and rich).
NUMERIC = "import numpy, scipy.spatial, igl"
FLOOR = f"{NUMERIC}, typer, typer._adapters, rich.console, rich.table"


def cases(files: dict[str, Path], twm: Path, before: Path | None) -> list[Case]:
    out = [
        Case("-", "imports alone: numpy, scipy, libigl", ROOT, ("-c", NUMERIC)),
        Case("-", "imports alone: the same, typer (pydantic), rich", ROOT, ("-c", FLOOR)),
    ]
    for name, scan in files.items():
        if before is not None:
            out.append(Case(name, "before, model.ply", before, ("register", str(scan), str(MODEL))))
        out += [
            Case(name, "one scan, model.ply", ROOT, ("register", str(scan), str(MODEL))),
            Case(name, "one scan, model.twm", ROOT, ("register", str(scan), str(twm))),
            Case(name, f"batch of {BATCH}, model.twm, per scan", ROOT,
                 ("register", *[str(scan)] * BATCH, str(twm)), BATCH),
        ]  # fmt: skip
    return out


def measure(args: argparse.Namespace, folder: Path) -> list[Timing]:
    files = inputs(folder)
    twm = folder / "model.twm"
    run(ROOT, ["prepare", str(MODEL), "--out", str(twm)])
    before = None if args.before == "none" else export(args.before, folder / "before")
    return timings(cases(files, twm, before), folder / "out.json", args.repeats)


def table(rows: list[Timing]) -> str:
    lines = [
        "| input | form | wall s | match s | overhead s | CPU s |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        c = r.case
        lines.append(
            f"| {c.input} | {c.form} | {r.wall:.3f} | {r.match:.3f} | {r.overhead:.3f} | "
            f"{r.cpu:.3f} |"
        )
    return "\n".join(lines)


def readme_table(rows: list[Timing]) -> str:
    """The same as the README shows it: a row per form, a column per input, each cell
    "wall = match + overhead" [s]; the imports alone below."""
    measured = [r for r in rows if r.case.input != "-"]
    inputs = list(dict.fromkeys(r.case.input for r in measured))
    forms = list(dict.fromkeys(r.case.form for r in measured))
    cell = {(r.case.form, r.case.input): r for r in measured}
    lines = [f"| form | {' | '.join(inputs)} |", "|---" * (len(inputs) + 1) + "|"]
    for form in forms:
        cells = [cell[form, i] for i in inputs]
        text = [f"{r.wall:.2f} = {r.match:.2f} + {r.overhead:.2f}" for r in cells]
        lines.append(f"| {form} | {' | '.join(text)} |")
    lines += [f"{r.case.form}: {r.wall:.2f} s" for r in rows if r.case.input == "-"]
    return "\n".join(lines)


def short(folder: Path) -> None:
    """One case: the .twm form on the xyz file (twice, the second with the bytecode
    cached); its output must be a result."""
    from registration.io.mesh_files import read_mesh

    xyz = write_xyz(folder, read_mesh(SCAN, points_only=True)[0])
    twm = folder / "model.twm"
    run(ROOT, ["prepare", str(MODEL), "--out", str(twm)])
    case = Case("xyz", "one scan, model.twm", ROOT, ("register", str(xyz), str(twm)))
    (timing,) = timings([case], folder / "out.json", 2)  # the first compiles
    result = json.loads((folder / "out.json").read_text())
    assert result["verdict"] == "accepted", result["verdict"]
    print(table([timing]))


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
    print()
    print(readme_table(rows))


if __name__ == "__main__":
    main()
