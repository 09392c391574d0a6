"""A job across the network against the same job in process, seed by seed.

    python bench/bench_network_job.py [--job skull] [--cell CELL] [--seeds 300 301 ...]
        [--speed 20] [--laser-latency MS] [--out DIR]

For each seed: `twincell run JOB --seed S` in process (the skull job, or the assembly job:
IR probing, a pick with the gripper, the screwer's touches); then `twincell serve JOB --seed
S` in a process of its own (a fresh real cell, its time --speed times the wall's) and
`twincell run JOB --seed S --controller ...` against it (its laser stamping each profile
--laser-latency ms after its exposure, which the job's calibration identifies), all in the
shipped cell --cell if given (point_laser: the laser on the controller's analog input, read
in the EGM stream). Prints each seed's status and target errors both ways and their
differences, the latency identified, the wall time of each stage both ways (the network's
overhead per stage), and the cell time.

The twin reads its encoders every control period and its laser at its own instants, so the
network job meets another draw of the cell's noise than the job in process. Each seed
therefore also runs in process once more with another draw (`--set cell.noise.draw=1`: the
same real cell, its object placed alike, run again): how far single targets move between two
runs of the same cell is the yardstick for how far they move across the network.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench_support.served_twin import served
from rich.console import Console
from rich.table import Table

from scenarios.configuration.config_files import load_config


def _twincell(*args: str, log: Path) -> float:
    """Run `twincell ARGS`, its output to `log`; its wall time [s]."""
    t0 = time.perf_counter()
    with log.open("w") as sink:
        subprocess.run([sys.executable, "-m", "scenarios.cli", *args], stdout=sink, check=False)
    return time.perf_counter() - t0


def _results(folder: Path) -> dict:
    return json.loads(next(folder.glob("*-*/results.json")).read_text())


def _network(
    job: str,
    seed: int,
    speed: float,
    latency_ms: float,
    out: Path,
    cell: tuple[str, ...],
    point: bool,
) -> tuple[dict, float]:
    """The job against its twin served; a `point` laser comes in the EGM stream, a line
    profiler on a stream of its own."""
    extra = ("--laser-latency", str(latency_ms), *cell)
    with served(job, seed, speed, out, *extra) as ports:
        stream = () if point else ("--profiles", f"127.0.0.1:{ports.profiles}")
        wall = _twincell(
            "run", job, "--seed", str(seed), "--out", str(out / "net"), *cell,
            "--controller", ports.url, "--egm-port", str(ports.egm), *stream,
            log=out / "net.log",
        )  # fmt: skip
    return _results(out / "net"), wall


def _differences(a: dict, b: dict) -> list[float]:
    """The absolute differences of the target errors [m] of two runs, target by target."""
    e_a = {t["name"]: t["error_m"] for t in a.get("targets", [])}
    e_b = {t["name"]: t["error_m"] for t in b.get("targets", [])}
    return [abs(e_b[n] - e_a[n]) for n in e_a if n in e_b]


def _largest(values: list[float]) -> float:
    return max(values) if values else float("nan")


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.3f}"


def _latency(result: dict) -> str:
    """The laser's latency the network job's calibration identified, with its uncertainty."""
    found = result.get("calibration") or {}
    if found.get("laser_latency_s") is None:
        return "-"
    return f"{found['laser_latency_s'] * 1e3:.2f} +- {found['laser_latency_sigma_s'] * 1e3:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", choices=("skull", "assembly"), default="skull")
    parser.add_argument("--cell", default=None, help="a shipped cell (default: the job's)")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(300, 310)))
    parser.add_argument("--speed", type=float, default=20.0)
    parser.add_argument("--laser-latency", type=float, default=0.0, metavar="MS")
    parser.add_argument("--out", type=Path, default=Path("/tmp/twincell_bench_network"))
    args = parser.parse_args()
    console = Console()
    cell = () if args.cell is None else ("--cell", args.cell)
    point = load_config(args.job, {}, args.cell).cell.laser.kind == "point"
    rows, stages_in, stages_net, worst, worst_again = [], {}, {}, 0.0, 0.0
    for seed in args.seeds:
        out = args.out / f"seed{seed}"
        out.mkdir(parents=True, exist_ok=True)
        wall_in = _twincell(
            "run", args.job, "--seed", str(seed), "--out", str(out / "in"), "--no-rrd", *cell,
            log=out / "in.log",
        )  # fmt: skip
        _twincell(
            "run", args.job, "--seed", str(seed), "--out", str(out / "again"), "--no-rrd", *cell,
            "--set", "cell.noise.draw=1", log=out / "again.log",
        )  # fmt: skip
        ours, wall_net = _network(args.job, seed, args.speed, args.laser_latency, out, cell, point)
        theirs = _results(out / "in")
        diffs = _differences(theirs, ours)
        again = _differences(theirs, _results(out / "again"))
        if ours["status"] == "incomplete":
            console.print(f"seed {seed}: network incomplete: {ours['reason']}")
        worst = max([worst, *diffs])
        worst_again = max([worst_again, *again])
        rows.append((seed, theirs, ours, _largest(diffs), _largest(again), wall_in, wall_net))
        for name, t in theirs["timings_s"].items():
            stages_in.setdefault(name, []).append(t)
        for name, t in ours.get("timings_s", {}).items():
            stages_net.setdefault(name, []).append(t)
        console.print(f"seed {seed}: in process {theirs['status']}, network {ours['status']}, "
                      f"largest target difference {_largest(diffs) * 1e3:.3f} mm (in process "
                      f"with another draw {_largest(again) * 1e3:.3f} mm)")  # fmt: skip
    title = f"{args.job} across the network (twin at speed {args.speed:g}) vs in process"
    table = Table(title=title)
    columns = (
        "seed", "status in / net", "rms in / net [mm]", "max in / net [mm]",
        "largest target diff [mm]", "same, another draw in process [mm]",
        "latency found [ms]", "cell time in / net [s]",
        "wall in / net [s]",
    )  # fmt: skip
    for column in columns:
        table.add_column(column, justify="right")
    for seed, theirs, ours, diff, diff_again, wall_in, wall_net in rows:
        table.add_row(
            str(seed),
            f"{theirs['status']} / {ours['status']}",
            f"{_mm(theirs.get('target_error_rms_m'))} / {_mm(ours.get('target_error_rms_m'))}",
            f"{_mm(theirs.get('target_error_max_m'))} / {_mm(ours.get('target_error_max_m'))}",
            f"{diff * 1e3:.3f}",
            f"{diff_again * 1e3:.3f}",
            _latency(ours),
            f"{theirs.get('cell_time_s', float('nan')):.0f} / "
            f"{ours.get('cell_time_s', float('nan')):.0f}",
            f"{wall_in:.0f} / {wall_net:.0f}",
        )
    console.print(table)
    stages = Table(title="wall time per stage, median over the seeds [s]")
    for column in ("stage", "in process", "network", "overhead"):
        stages.add_column(column, justify="right")
    for name in stages_net:
        a = statistics.median(stages_in.get(name, [0.0]))
        b = statistics.median(stages_net[name])
        stages.add_row(name, f"{a:.1f}", f"{b:.1f}", f"{b - a:+.1f}")
    console.print(stages)
    console.print(
        f"largest per-target difference over the seeds: {worst * 1e3:.3f} mm across the "
        f"network, {worst_again * 1e3:.3f} mm in process with another draw"
    )


if __name__ == "__main__":
    main()
