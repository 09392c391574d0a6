"""Benchmark of the skull job: where the time goes, before and after, and accuracy over seeds.

    python bench/bench_skull.py [--seeds 5] [--repeats 3] [--before 70a6fa0]
                                [--out /tmp/twincell_bench_runs] [--short]

Prints four tables:
1. the whole `twincell run skull` command (a fresh process, the recording on), before (the
   code at --before, exported with `git archive`, first on the process's PYTHONPATH) and
   after (this checkout), each with an empty cache (the first run on a fresh machine: the
   phantom built, the scan planned) and with the cache it filled (a run again); the median
   of --repeats, the versions alternating;
2. the job's stages, with the recording on and off (same seed);
3. matching one scan with the job's thinning (3 mm voxels, 6000 points) against matching
   every scan point (the peer), same data: time, pose and target errors;
4. target errors against the goals (RMS <= 0.5 mm, max <= 1 mm) for several seeds.

Seed 0 without the recording runs once and serves tables 3 and 4. --short: this checkout's
command once, with an empty cache, serving every table (the recording on only;
bench_recording.py compares on and off).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cell import FixedMesh, nominal_T_base_table
from cell.sim import make_cell
from registration import Acceptance, MeshModel, pose_error, transform_points
from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import object_models
from scenarios.jobs.runner import RunOptions, run_job
from scenarios.offline.localization import localize
from scenarios.outputs.run_files import read_ply
from scenarios.realcell.real_placement import draw_true_pose
from scenarios.realcell.setup import cell_config

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("cell", "models", "registration", "scenarios")
#: The code before the fast-feedback work (the main job's speed, the plan cache).
BEFORE = "70a6fa0"


def _cli_run(
    out: Path, seed: int, code: Path | None = None, cache: Path | None = None
) -> tuple[float, dict]:
    """`twincell run skull` in a fresh process: wall time [s] and results.json. `code`: a
    version's packages, first on the PYTHONPATH; `cache`: the cache folder."""
    env = dict(os.environ)
    if code is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(code), *filter(None, [env.get("PYTHONPATH")])])
    if cache is not None:
        env["TWINCELL_CACHE_DIR"] = str(cache)
    command = [sys.executable, "-c", "from scenarios.cli import main; main()"]
    t0 = time.perf_counter()
    done = subprocess.run(
        [*command, "run", "skull", "--seed", str(seed), "--out", str(out), "--quiet"],
        check=False, capture_output=True, env=env, cwd=out.parent, text=True,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"twincell run skull failed ({code or 'this checkout'}):\n{done.stderr}")
    return wall, json.loads((out / "latest" / "results.json").read_text())


def _export(rev: str, into: Path) -> Path:
    """The packages at commit `rev`, written into `into`."""
    done = subprocess.run(
        ["git", "-C", str(ROOT), "archive", "--format=tar", rev, *PACKAGES], capture_output=True
    )
    if done.returncode != 0:
        raise SystemExit(f"commit {rev} is not in this clone: {done.stderr.decode()}")
    with tarfile.open(fileobj=io.BytesIO(done.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def command_table(args: argparse.Namespace, out: Path, tmp: Path) -> tuple[Path, dict]:
    """Table 1: the whole command, before and after, cold and warm; returns this checkout's
    last run folder and its results."""
    versions: dict[str, Path | None] = {"after": None}
    if not args.short:
        versions["before"] = _export(args.before, tmp / "before")
    walls: dict[tuple[str, str], list[float]] = {}
    totals: dict[tuple[str, str], list[float]] = {}
    last: tuple[Path, dict] | None = None
    for repeat in range(args.repeats):
        order = list(versions) if repeat % 2 == 0 else list(reversed(versions))
        for version in order:
            cache = tmp / f"cache-{version}-{repeat}"  # empty: the first run on this machine
            for state in ("empty cache", "cache warm")[: 1 if args.short else 2]:
                folder = out / f"{version}-{repeat}"
                wall, results = _cli_run(folder, 0, versions[version], cache)
                if ("plan_cache" in results) != (version == "after"):  # results.json says
                    raise SystemExit(f"the {version} run did not run the {version} code")
                walls.setdefault((version, state), []).append(wall)
                totals.setdefault((version, state), []).append(results["timings_s"]["total"])
                if version == "after":
                    last = ((folder / "latest").resolve(), results)
    table = Table(title=f"twincell run skull, seed 0: wall time \\[s], median of {args.repeats}")
    for col in ("version", "cache", "whole command", "job (timings_s.total)"):
        table.add_column(col, justify="right")
    for (version, state), values in walls.items():
        name = "this checkout" if version == "after" else args.before
        table.add_row(
            name, state, f"{statistics.median(values):.1f}",
            f"{statistics.median(totals[(version, state)]):.1f}",
        )  # fmt: skip
    Console().print(table)
    assert last is not None
    return last


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--out", default="/tmp/twincell_bench_runs")
    parser.add_argument("--short", action="store_true", help="one run, empty cache")
    parser.add_argument("--repeats", type=int, default=3, help="of the whole command")
    parser.add_argument("--before", default=BEFORE, help="the commit to compare with")
    args = parser.parse_args()
    if args.short:
        args.seeds, args.repeats = 1, 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    console = Console()

    # 1. The whole command, before and after.
    with tempfile.TemporaryDirectory(prefix="twincell-skull-") as tmp:
        rrd, with_rrd = command_table(args, out, Path(tmp))

    # 2. The stages, recording on and off.
    if args.short:  # the recorded run serves every table
        plain, without = rrd, {"timings_s": {}, "seconds": float("nan")}
    else:
        plain, _ = run_job("skull", seed=0, out=out, options=RunOptions(rrd=False))
        without = json.loads((plain / "results.json").read_text())
    table = Table(title="skull job, seed 0: time \\[s] (2 cores)")
    table.add_column("stage")
    table.add_column("rerun on", justify="right")
    table.add_column("rerun off", justify="right")
    stages = ("setup", "calibrate", "scan", "register", "check", "verify", "execute")
    for key in (*stages, "export_execute", "total"):
        on, off = with_rrd["timings_s"].get(key), without["timings_s"].get(key)
        table.add_row(key, "-" if on is None else f"{on:.1f}", "-" if off is None else f"{off:.1f}")
    table.add_row("job incl. outputs", f"{with_rrd['seconds']:.1f}", f"{without['seconds']:.1f}")
    console.print(table)

    # 2. Thinning against every point, same scan, both against the truth (rebuilt from the
    # seed: the real phantom's pose and the table follow from it).
    config = load_config("skull")
    points = read_ply(plain / "scan.ply")
    virtual, real = object_models(config)
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 5]))
    T_table_true = draw_true_pose(config.cell.object.placement, real.mesh.vertices, rng)
    fixture = FixedMesh("object", real.mesh.vertices, real.mesh.faces, T_table_true)
    _, truth = make_cell(cell_config(config.cell.noise, config.seed, (fixture,)))
    T_base_true = truth.T_base_object("object")
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    acceptance = Acceptance(max_rms=1e-3, max_predicted_tre=1e-3)
    registration = config.localization.registration
    targets = np.array([h.p_entry for h in virtual.burr_holes])
    table = Table(title=f"matching one scan ({len(points)} object points), seed 0")
    for col in ("points used", "seconds", "verdict", "pose error [deg, mm]", "target max [mm]"):
        table.add_column(col.replace("[", "\\["), justify="right")
    for label, max_points, voxel in (
        ("job: 3 mm voxels, 6000", registration.max_points, registration.voxel_m),
        ("peer: every point", len(points), 0.0),
    ):
        t0 = time.perf_counter()
        located = localize(points, shape, max_points, acceptance, 0, voxel)
        seconds = time.perf_counter() - t0
        T_base_estimate = nominal_T_base_table(0.0) @ located.T_table_object
        rot, trans = pose_error(T_base_estimate, T_base_true)
        moved = np.linalg.norm(
            transform_points(T_base_estimate, targets) - transform_points(T_base_true, targets),
            axis=1,
        )
        table.add_row(
            f"{label}: {len(located.points_used)}",
            f"{seconds:.2f}",
            located.result.verdict,
            f"{np.degrees(rot):.3f}, {trans * 1e3:.3f}",
            f"{moved.max() * 1e3:.3f}",
        )
    console.print(table)

    # 3. Accuracy over seeds (recording off).
    table = Table(title="skull job: target errors over seeds \\[mm] (goal RMS <= 0.5, max <= 1.0)")
    for col in (
        "seed",
        "status",
        "ambiguity",
        "pose \\[deg, mm]",
        "RMS",
        "max",
        "registration share max",
        "goal",
    ):
        table.add_column(col, justify="right")
    met = 0
    for seed in range(args.seeds):
        folder = plain
        if seed > 0:
            folder, _ = run_job("skull", seed=seed, out=out, options=RunOptions(rrd=False))
        r = json.loads((folder / "results.json").read_text())
        reg = r["registration"]
        if r["status"] != "complete":
            table.add_row(
                str(seed), r["status"], f"{reg['ambiguity']:.2f}", "-", "-", "-", "-", "no"
            )
            continue
        ok = r["target_error_rms_m"] <= 0.5e-3 and r["target_error_max_m"] <= 1.0e-3
        met += ok
        share = max(t["registration_error_m"] for t in r["targets"])
        table.add_row(
            str(seed),
            r["status"],
            f"{reg['ambiguity']:.2f}",
            f"{reg['rotation_error_deg']:.3f}, {reg['translation_error_m'] * 1e3:.3f}",
            f"{r['target_error_rms_m'] * 1e3:.3f}",
            f"{r['target_error_max_m'] * 1e3:.3f}",
            f"{share * 1e3:.3f}",
            "yes" if ok else "no",
        )
    console.print(table)
    console.print(f"goals met in {met} of {args.seeds} seeds; recording of seed 0 in {rrd}")


if __name__ == "__main__":
    main()
