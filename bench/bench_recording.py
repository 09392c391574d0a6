"""What the recording costs: the skull job with and without run.rrd, and the file itself.

    python bench/bench_recording.py [--seeds 3] [--out /tmp/twincell_bench_rec] [--short]

For each seed, `twincell run skull` in a fresh process with the recording and without it
(the order alternates from seed to seed), wall time; then run.rrd's size and chunk count,
beside the peer: the same file compacted by rerun's own `rerun rrd optimize`. Goals: the run
with the recording at most 1.5x the run without, run.rrd under 20 MB.

--short: one seed (two runs of the skull job).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

BIN = Path(sys.executable).parent


def _run(out: Path, seed: int, rrd: bool) -> float:
    """Wall time [s] of the run, into `out`/with or `out`/without."""
    folder = out / ("with" if rrd else "without")
    command = [str(BIN / "twincell"), "run", "skull", "--seed", str(seed), "--out", str(folder)]
    command += ["--quiet"] + ([] if rrd else ["--no-rrd"])
    t0 = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - t0


def _chunks(path: Path) -> int:
    done = subprocess.run(
        [str(BIN / "rerun"), "rrd", "stats", str(path)], capture_output=True, text=True, check=True
    )
    found = re.search(r"num_chunks = ([\d ]+)", done.stdout + done.stderr)
    return int(found.group(1).replace(" ", "")) if found else -1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--out", default="/tmp/twincell_bench_rec")
    parser.add_argument("--short", action="store_true", help="one seed")
    args = parser.parse_args()
    if args.short:
        args.seeds = 1
    out = Path(args.out)
    console = Console()
    table = Table(title="skull job: wall time \\[s] of the whole command (2 cores)")
    for col in ("seed", "with run.rrd", "without", "ratio", "run.rrd [MB]", "chunks"):
        table.add_column(col, justify="right")
    ratios, sizes = [], []
    last = None
    for seed in range(args.seeds):
        order = (True, False) if seed % 2 == 0 else (False, True)
        wall = {rrd: _run(out, seed, rrd) for rrd in order}
        last = (out / "with" / "latest" / "run.rrd").resolve()
        size = last.stat().st_size / 1e6
        ratio = wall[True] / wall[False]
        ratios.append(ratio)
        sizes.append(size)
        table.add_row(str(seed), f"{wall[True]:.1f}", f"{wall[False]:.1f}", f"{ratio:.2f}",
                      f"{size:.1f}", str(_chunks(last)))  # fmt: skip
    console.print(table)
    assert last is not None
    optimized = last.with_name("optimized.rrd")
    with optimized.open("wb") as f:
        subprocess.run([str(BIN / "rerun"), "rrd", "optimize", str(last)], stdout=f, check=True,
                       stderr=subprocess.DEVNULL)  # fmt: skip
    peer = Table(title=f"run.rrd of seed {args.seeds - 1}: ours vs rerun rrd optimize")
    for col in ("file", "size [MB]", "chunks"):
        peer.add_column(col, justify="right")
    peer.add_row("ours", f"{last.stat().st_size / 1e6:.1f}", str(_chunks(last)))
    peer.add_row("rerun rrd optimize", f"{optimized.stat().st_size / 1e6:.1f}",
                 str(_chunks(optimized)))  # fmt: skip
    console.print(peer)
    worst = max(ratios)
    console.print(
        f"goal: with / without <= 1.5: worst {worst:.2f} {'met' if worst <= 1.5 else 'NOT met'}; "
        f"run.rrd < 20 MB: largest {max(sizes):.1f} MB {'met' if max(sizes) < 20 else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
