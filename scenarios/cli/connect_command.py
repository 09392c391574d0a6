"""`twincell connect`: what a controller lacks for the jobs."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer

from scenarios.cli.help_format import argument, option

if TYPE_CHECKING:
    from scenarios.irc5.controller_check import ControllerCheck

EXAMPLES = (
    "twincell connect http://192.168.125.1:80",
    "twincell connect http://127.0.0.1:8080 --egm-port 6510 --json connect.json",
)


def connect(
    url: Annotated[str, argument("URL", "The controller's Robot Web Services: http://HOST:PORT.")],
    timeout: Annotated[
        float, option("--timeout", "SECONDS", "How long to wait for each answer.", min=0.1)
    ] = 5.0,
    json_file: Annotated[
        str | None, option("--json", "FILE", "Also write the findings to this JSON file.")
    ] = None,
    egm_port: Annotated[
        int | None,
        option(
            "--egm-port",
            "PORT",
            "The UDP port the job will be given: the controller's UDP device must stream to it.",
            min=1,
            max=65535,
        ),
    ] = None,
) -> None:
    """Say what a controller lacks for the jobs, moving nothing.

    Asks the controller at URL (an IRC5 with RobotWare 6, or `twincell serve`) for its
    RobotWare and options, the signals of twincell's EIO.cfg, the UDP device TcPC its EGM
    streams to (this computer's address; with --egm-port, that port), the helper module
    TcHelper and its version, the motors, the operating mode, mastership and the program's state;
    says what each is and what to change. The user and password come from
    TWINCELL_RWS_USER and TWINCELL_RWS_PASSWORD, or the file TWINCELL_RWS_CREDENTIALS
    names. Nothing moves. Exit status 0 if the controller has all the jobs need, 1 if not.
    """
    from urllib.parse import urlparse

    from scenarios.irc5.controller_check import check_controller
    from scenarios.irc5.rws_link import RwsLink
    from scenarios.jobs.network_job import credentials
    from scenarios.scenario_errors import ScenarioError

    parsed = urlparse(url)
    if parsed.scheme not in ("http", "https") or not parsed.hostname or not parsed.port:
        raise ScenarioError(
            f"URL {url!r}: give the controller's Robot Web Services as http://HOST:PORT, "
            "e.g. http://192.168.125.1:80"
        )
    user, password = credentials()
    link = RwsLink(url, user, password, timeout)
    try:
        report = check_controller(link, egm_port)
    finally:
        link.close()
    typer.echo(render(report))
    if json_file is not None:
        write_json(report, json_file)
    if not report.ok:
        raise typer.Exit(1)


def render(report: ControllerCheck) -> str:
    """The findings as lines: each with ok or MISSING, and what to change under it."""
    width = max(len(f.what) for f in report.findings)
    lines = [f"controller {report.url}"]
    for f in report.findings:
        found = f"{f.found} (needed by {f.needed_by} only)" if f.needed_by else f.found
        lines.append(f"  {'ok' if f.ok else 'MISSING':8} {f.what:{width}}  {found}")
        if f.change:
            lines.append(f"  {'':8} {'':{width}}  -> {f.change}")
    missing, some = len(report.missing), len(report.missing_for_some)
    if missing:
        lines.append(
            f"{missing} of {len(report.findings)} not as the jobs need them: change them, then "
            "connect again"
        )
    elif some:
        lines.append(
            f"all that every job needs as it needs them; {some} that only some jobs need "
            "missing (each says which jobs)"
        )
    else:
        lines.append(f"all {len(report.findings)} as the jobs need them")
    return "\n".join(lines)


def write_json(report: ControllerCheck, path: str) -> None:
    """The findings and whether the controller is `ok`, as JSON, completely or not at all."""
    import json
    from pathlib import Path

    from models.atomic import write_text
    from scenarios.results.json_converter import unstructure
    from scenarios.scenario_errors import ScenarioError

    target = Path(path)
    if not target.parent.is_dir():
        raise ScenarioError(f"--json {path!r}: its folder {str(target.parent)!r} does not exist")
    data = unstructure(report) | {"ok": report.ok}
    write_text(target, json.dumps(data, indent=2) + "\n")
