"""The laser's latency identified on a sphere, for latencies the twin's laser is given.

    python bench/bench_laser_latency.py [--latencies 0 8 20] [--seed 0] [--speed 20]

For each latency: `twincell serve skull --laser-latency MS` in a process of its own; a client
across the network fetches the laser, moves the table to the calibration's last position and
sweeps the highest sphere forth and back at 0.1 and 0.25 m/s, the arm nominal
(scenarios.offline.laser_latency.latency_alone). Prints the latency found, its uncertainty
and its error against the twin's (the truth, known only to this script), and the
identification's cell and wall time (the laser fetched, swept, put back).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bench_support.served_twin import Ports, served
from rich.console import Console
from rich.table import Table

from cell import LaserConfig
from cell.irb2400_arm import irb2400
from models.robot import RACK_POS
from scenarios.irc5.egm_feedback import EgmFeedback
from scenarios.irc5.line_profiler import ProfileBuffer, ProfileStream
from scenarios.irc5.remote_controller import RemoteController
from scenarios.irc5.rws_link import RwsLink
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.laser_latency import LatencyEstimate, latency_alone


def _identify(ports: Ports) -> tuple[LatencyEstimate, float, float]:
    """The latency found through the twin at `ports`; the identification's cell and wall
    time [s] (the laser fetched, the sweeps, the laser put back)."""
    robot = irb2400()
    client = RemoteController(
        RwsLink(ports.url, "Default User", "robotics", 5.0),
        EgmFeedback(ports.egm),
        ProfileBuffer(ProfileStream("127.0.0.1", ports.profiles)),
        robot,
        robot.kinematics(),
        RACK_POS,
        LaserConfig(),
    )
    try:
        t0, wall0 = client.time_s, time.perf_counter()
        found = latency_alone(client, DEFAULT_ARTIFACT, -0.05)
        return found, client.time_s - t0, time.perf_counter() - wall0
    finally:
        client.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--latencies", type=float, nargs="+", default=[0.0, 8.0, 20.0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--speed", type=float, default=20.0)
    args = parser.parse_args()
    table = Table(title=f"the laser's latency found on a sphere (skull cell, seed {args.seed})")
    for column in (
        "twin's latency [ms]", "found [ms]", "error [ms]", "sigma [ms]", "lines", "points",
        "residual rms [mm]", "cell / wall time [s]",
    ):  # fmt: skip
        table.add_column(column, justify="right")
    with tempfile.TemporaryDirectory() as folder:
        for latency_ms in args.latencies:
            out = Path(folder) / f"latency{latency_ms:g}"
            extra = ("--laser-latency", str(latency_ms))
            with served("skull", args.seed, args.speed, out, *extra) as ports:
                found, cell_s, wall_s = _identify(ports)
            table.add_row(
                f"{latency_ms:g}",
                f"{found.latency_s * 1e3:.3f}",
                f"{found.latency_s * 1e3 - latency_ms:+.3f}",
                f"{found.sigma_s * 1e3:.3f}",
                str(found.lines),
                str(found.points),
                f"{found.residual_rms_m * 1e3:.3f}",
                f"{cell_s:.1f} / {wall_s:.1f}",
            )
    Console().print(table)


if __name__ == "__main__":
    main()
