"""`twincell serve`: a job's real cell served as an ABB IRC5 controller (Robot Web Services,
EGM) until stopped."""

from __future__ import annotations

from typing import Annotated, Any

import typer


def serve(
    name: Annotated[
        str,
        typer.Argument(help="A shipped job (skull, assembly), a CONFIG.yaml, or a run folder."),
    ],
    rws: Annotated[
        str, typer.Option("--rws", help="HOST:PORT the Robot Web Services answer on.")
    ] = "127.0.0.1:8080",
    host: Annotated[
        str | None,
        typer.Option("--host", help="Bind to this host instead of --rws's (e.g. 0.0.0.0)."),
    ] = None,
    egm_port: Annotated[
        int | None,
        typer.Option("--egm-port", min=1, max=65535, help="The EGM client's UDP port."),
    ] = None,
    egm_host: Annotated[
        str, typer.Option("--egm-host", help="The EGM client's host.")
    ] = "127.0.0.1",
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, help="The real cell's seed (default: the job's).")
    ] = None,
    speed: Annotated[
        float,
        typer.Option("--speed", min=0.01, help="The cell's time runs N times the wall clock's."),
    ] = 1.0,
    opmode: Annotated[
        str,
        typer.Option(
            "--opmode",
            help="The operation mode: AUTO, or MANR (manual: clients read, but neither start "
            "programs nor write).",
        ),
    ] = "AUTO",
    user: Annotated[
        list[str] | None,
        typer.Option(
            "--user",
            help="NAME:PASSWORD of a user (repeatable; default the "
            "controller's Default User:robotics).",
        ),
    ] = None,
    out: Annotated[
        str, typer.Option("--out", help="Folder that holds the serve folders.")
    ] = "runs",
    spawn: Annotated[
        bool, typer.Option("--spawn", help="Show the cell live in a rerun viewer.")
    ] = False,
    rrd: Annotated[
        bool, typer.Option("--rrd", help="Write serve.rrd into the serve folder.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Serve a job's real cell as an ABB IRC5 controller: Robot Web Services (HTTP, digest
    authentication) and EGM (UDP), until Ctrl-C. Programs a client loads and starts run as
    `twincell execute` runs them; each one run to its end is measured against the truth in
    the serve folder (executions/)."""
    from scenarios.jobs.serve import serve_job
    from scenarios.twin.server import ServeOptions, parse_address, parse_users

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    rws_host, rws_port = parse_address(rws)
    options = ServeOptions(host or rws_host, rws_port, egm_port, egm_host, parse_users(user or []))
    serving = serve_job(name, options, seed=seed, speed=speed, out=out, spawn=spawn, rrd=rrd,
                        progress=progress, opmode=opmode.upper())  # fmt: skip
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
