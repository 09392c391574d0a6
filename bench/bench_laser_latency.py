"""The laser's latency identified on a sphere, for latencies the twin's laser is given.

    python bench/bench_laser_latency.py [--latencies 0 8 20] [--seed 0] [--speed 20]

For each latency: `twincell serve skull --laser-latency MS` in a process of its own; a client
across the network fetches the laser, moves the table to the calibration's last position and
sweeps the highest sphere forth and back at 0.1 and 0.25 m/s (scenarios.offline.laser_latency),
the arm nominal. Prints the latency found, its uncertainty and its error against the twin's
(the truth, known only to this script), and the sweeps' cell and wall time.
"""

from __future__ import annotations

import argparse
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from cell import LaserConfig, nominal_T_base_table
from cell.irb2400_arm import irb2400
from models.robot import RACK_POS
from scenarios.irc5.egm_feedback import EgmFeedback
from scenarios.irc5.line_profiler import ProfileBuffer, ProfileStream
from scenarios.irc5.remote_controller import RemoteController
from scenarios.irc5.rws_link import RwsLink
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.cell_model import CellModel
from scenarios.offline.laser_latency import (
    LatencyEstimate,
    LatencyPlan,
    identify_latency,
    sweep_sphere,
)


def _free(kind: socket.SocketKind) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _identify(rws: int, egm: int, profiles: int) -> tuple[LatencyEstimate, float, float]:
    """The latency found through the twin at these ports; the sweeps' cell and wall time [s]."""
    robot = irb2400()
    client = RemoteController(
        RwsLink(f"http://127.0.0.1:{rws}", "Default User", "robotics", 5.0),
        EgmFeedback(egm),
        ProfileBuffer(ProfileStream("127.0.0.1", profiles)),
        robot,
        robot.kinematics(),
        RACK_POS,
        LaserConfig(),
    )
    try:
        client.move_joints(client.q_home)
        client.change_tool("laser")
        client.move_table(-0.05)
        T = nominal_T_base_table(client.table_position())
        centres = DEFAULT_ARTIFACT.centres_table @ T[:3, :3].T + T[:3, 3]
        t0, wall0 = client.time_s, time.perf_counter()
        sweeps = sweep_sphere(client, centres, DEFAULT_ARTIFACT.radius_m, LatencyPlan())
        cell_s, wall_s = client.time_s - t0, time.perf_counter() - wall0
        found = identify_latency(
            sweeps,
            CellModel.nominal(client.kinematics),
            client.laser_directions_tcp,
            DEFAULT_ARTIFACT.radius_m,
            client.laser_latency_s,
        )
        client.move_joints(client.q_home)
        client.return_tool()
    finally:
        client.close()
    return found, cell_s, wall_s


def _served(
    latency_ms: float, seed: int, speed: float, out: Path
) -> tuple[LatencyEstimate, float, float]:
    rws, egm = _free(socket.SOCK_STREAM), _free(socket.SOCK_DGRAM)
    profiles = _free(socket.SOCK_STREAM)
    log = out / f"serve{latency_ms:g}.log"
    with log.open("w") as sink:
        server = subprocess.Popen(
            [sys.executable, "-m", "scenarios.cli", "serve", "skull", "--seed", str(seed),
             "--speed", str(speed), "--rws", f"127.0.0.1:{rws}", "--egm-port", str(egm),
             "--profiles", str(profiles), "--laser-latency", str(latency_ms),
             "--out", str(out / f"serve{latency_ms:g}"), "--quiet"],
            stdout=sink, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        while "serving http" not in log.read_text():
            if server.poll() is not None:
                raise RuntimeError(log.read_text())
            time.sleep(0.1)
        return _identify(rws, egm, profiles)
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=60)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--latencies", type=float, nargs="+", default=[0.0, 8.0, 20.0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--speed", type=float, default=20.0)
    args = parser.parse_args()
    table = Table(title=f"the laser's latency found on a sphere (skull cell, seed {args.seed})")
    for column in (
        "twin's latency [ms]", "found [ms]", "error [ms]", "sigma [ms]", "lines", "points",
        "residual rms [mm]", "sweeps' cell / wall time [s]",
    ):  # fmt: skip
        table.add_column(column, justify="right")
    with tempfile.TemporaryDirectory() as folder:
        for latency_ms in args.latencies:
            found, cell_s, wall_s = _served(latency_ms, args.seed, args.speed, Path(folder))
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
