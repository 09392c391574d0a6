"""`twincell serve` in a process of its own for the network benchmarks: free ports on this
machine, its lines to a log, stopped with SIGTERM at the end."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Ports:
    """The served controller's RWS port, the EGM client's UDP port, the profiles' TCP port."""

    rws: int
    egm: int
    profiles: int

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.rws}"


def free_port(kind: socket.SocketKind) -> int:
    """A port of `kind` (SOCK_STREAM: TCP, SOCK_DGRAM: UDP) free on 127.0.0.1 now."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def served(job: str, seed: int, speed: float, out: Path, *extra: str) -> Iterator[Ports]:
    """`twincell serve JOB --seed SEED --speed SPEED EXTRA...`, its serve folder and log
    (serve.log) in `out`, until the block ends."""
    ports = Ports(
        free_port(socket.SOCK_STREAM), free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_STREAM)
    )
    out.mkdir(parents=True, exist_ok=True)
    log = out / "serve.log"
    with log.open("w") as sink:
        server = subprocess.Popen(
            [sys.executable, "-m", "scenarios.cli", "serve", job, "--seed", str(seed),
             "--speed", str(speed), "--rws", f"127.0.0.1:{ports.rws}",
             "--egm-port", str(ports.egm), "--profiles", str(ports.profiles),
             "--out", str(out / "serve"), "--quiet", *extra],
            stdout=sink, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        while "serving http" not in log.read_text():
            if server.poll() is not None:
                raise RuntimeError(log.read_text())
            time.sleep(0.1)
        yield ports
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=60)
