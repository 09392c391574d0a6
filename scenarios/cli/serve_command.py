"""`twincell serve`: a job's real cell served as an ABB IRC5 controller (Robot Web Services,
EGM) until stopped."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from scenarios.cli.help_format import argument, flag, option
from scenarios.cli.progress_lines import progress_lines
from scenarios.cli.run_command import CellOption

# The help's panels of `twincell serve`.
CONTROLLER = "Controller"
EGM = "EGM"
LASER = "Laser"
NETWORK = "Network faults"
CELL = "Cell"
OUTPUT = "Output"

EXAMPLES = (
    "twincell serve skull --speed 5",
    "twincell serve runs/latest --rws 127.0.0.1:8081",
    "twincell serve my_job.yaml --cell my_cell.yaml --seed 3",
)


JobArgument = Annotated[
    str, argument("JOB", "A shipped job (skull, assembly), a CONFIG.yaml, or a run folder.")
]
RwsOption = Annotated[
    str, option("--rws", "HOST:PORT", "Where the Robot Web Services answer.", CONTROLLER)
]
OpmodeOption = Annotated[
    str,
    option(
        "--opmode",
        "[AUTO|MANR]",
        "The operation mode: AUTO, or MANR (manual: clients read, but neither start "
        "programs nor write).",
        CONTROLLER,
    ),
]
HostOption = Annotated[
    str | None,
    option("--host", "HOST", "Bind to this host instead of --rws's (e.g. 0.0.0.0).", CONTROLLER),
]
UserOption = Annotated[
    list[str] | None,
    option(
        "--user",
        "NAME:PASSWORD",
        "A user (repeatable; default the controller's Default User:robotics).",
        CONTROLLER,
    ),
]
EgmPortOption = Annotated[
    int | None,
    option("--egm-port", "PORT", "The EGM client's UDP port.", EGM, min=1, max=65535),
]
EgmHostOption = Annotated[str, option("--egm-host", "HOST", "The EGM client's host.", EGM)]
ProfilesOption = Annotated[
    int | None,
    option(
        "--profiles",
        "PORT",
        "Serve the line laser's profiles on this TCP port (0: any free one).",
        LASER,
        min=0,
        max=65535,
    ),
]
LaserClockOption = Annotated[
    float | None,
    option(
        "--laser-clock",
        "SECONDS",
        "The laser's clock at the controller's time 0 [s] (default: the Unix time at start, "
        "as a sensor synchronised by PTP keeps).",
        LASER,
    ),
]
RwsLatencyOption = Annotated[
    float,
    option("--rws-latency", "MS", "Each RWS answer this late [ms].", NETWORK, min=0.0),
]
RwsJitterOption = Annotated[
    float,
    option(
        "--rws-jitter", "MS", "... and up to this much later still, at random [ms].", NETWORK,
        min=0.0,
    ),
]  # fmt: skip
EgmLossOption = Annotated[
    float,
    option("--egm-loss", "SHARE", "The share of EGM packets lost (0 to 1).", NETWORK, min=0.0,
           max=0.99),
]  # fmt: skip
LaserLatencyOption = Annotated[
    float,
    option(
        "--laser-latency", "MS",
        "The laser stamps each profile this long after its exposure (a point laser: its input "
        "shows each distance this long late) [ms].", LASER, min=0.0,
        max=500.0,
    ),
]  # fmt: skip
LaserDriftOption = Annotated[
    float,
    option("--laser-drift", "PPM", "The laser's clock runs this fast [ppm].", NETWORK),
]
SeedOption = Annotated[
    int | None,
    option("--seed", "INTEGER", "The real cell's seed (default: the job's).", CELL, min=0),
]
SpeedOption = Annotated[
    float,
    option("--speed", "FLOAT", "The cell's time runs N times the wall clock's.", CELL, min=0.01),
]
SetOption = Annotated[
    list[str] | None,
    option(
        "--set",
        "KEY=VALUE",
        "Set a configuration value of the job by its dotted key, as `twincell run --set` "
        "does; repeatable.",
        CELL,
    ),
]
OutOption = Annotated[str, option("--out", "DIR", "Folder that holds the serve folders.", OUTPUT)]
SpawnOption = Annotated[bool, flag("--spawn", "Show the cell live in a rerun viewer.", OUTPUT)]
RrdOption = Annotated[bool, flag("--rrd", "Write serve.rrd into the serve folder.", OUTPUT)]
QuietOption = Annotated[bool, flag("--quiet", "No progress lines.", OUTPUT)]


def serve(
    name: JobArgument,
    rws: RwsOption = "127.0.0.1:8080",
    opmode: OpmodeOption = "AUTO",
    host: HostOption = None,
    user: UserOption = None,
    egm_port: EgmPortOption = None,
    egm_host: EgmHostOption = "127.0.0.1",
    profiles: ProfilesOption = None,
    laser_clock: LaserClockOption = None,
    rws_latency: RwsLatencyOption = 0.0,
    rws_jitter: RwsJitterOption = 0.0,
    egm_loss: EgmLossOption = 0.0,
    laser_drift: LaserDriftOption = 0.0,
    laser_latency: LaserLatencyOption = 0.0,
    seed: SeedOption = None,
    speed: SpeedOption = 1.0,
    cell: CellOption = None,
    assign: SetOption = None,
    out: OutOption = "runs",
    spawn: SpawnOption = False,
    rrd: RrdOption = False,
    quiet: QuietOption = False,
) -> None:
    """Serve a job's real cell as an ABB IRC5 controller (RWS, EGM).

    Robot Web Services (HTTP, digest authentication) and EGM (UDP), until Ctrl-C. Programs a
    client loads and starts run as `twincell execute` runs them; each one run to its end is
    measured against the truth in the serve folder (executions/).
    """
    import time

    from scenarios.configuration.config_files import parse_assignment
    from scenarios.jobs.serve import serve_job
    from scenarios.twin.network_faults import NetworkFaults
    from scenarios.twin.sensor_streams import LaserStream
    from scenarios.twin.server import ServeOptions, parse_address, parse_users

    rws_host, rws_port = parse_address(rws)
    users = parse_users(user or [])
    offset = time.time() if laser_clock is None else laser_clock
    laser = LaserStream(
        clock_offset_s=offset, drift_ppm=laser_drift, latency_s=laser_latency * 1e-3
    )
    faults = NetworkFaults(rws_latency * 1e-3, rws_jitter * 1e-3, egm_loss)
    options = ServeOptions(
        host or rws_host, rws_port, egm_port, egm_host, users, opmode.upper(), profiles, laser,
        faults,
    )  # fmt: skip
    overrides = dict(parse_assignment(text) for text in assign or [])
    serving = serve_job(name, options, seed=seed, speed=speed, out=out, spawn=spawn, rrd=rrd,
                        progress=progress_lines(quiet),
                        overrides=overrides, cell=cell)  # fmt: skip
    typer.echo(f"serving {serving.url} (Ctrl-C to stop); serve folder: {serving.folder}")
    _serve_until_stopped(serving)


def _serve_until_stopped(serving: Any) -> None:
    """Serve until SIGINT (Ctrl-C) or SIGTERM, then close the servers and say what ran."""
    import contextlib
    import signal
    import threading

    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda _s, _f: done.set())
    try:
        with contextlib.suppress(KeyboardInterrupt):
            while not done.wait(0.5):
                continue
    finally:
        serving.close()
    n = len(serving.executions)
    typer.echo(f"stopped; {n} program{'' if n == 1 else 's'} measured in {serving.folder}")
