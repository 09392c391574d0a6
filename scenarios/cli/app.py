"""The `twincell` command line: the typer app, assembled from one module per command
(scenarios.cli.*_command), and its entry point. Each command imports what it needs when it
runs, so that `twincell --help` stays fast."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from scenarios.cli.campaign_command import campaign
from scenarios.cli.check_command import check
from scenarios.cli.execute_command import execute
from scenarios.cli.exit_status import run_command_line
from scenarios.cli.model_command import model
from scenarios.cli.prepare_command import prepare
from scenarios.cli.rapid_command import rapid
from scenarios.cli.register_command import register
from scenarios.cli.run_command import run
from scenarios.cli.serve_command import serve

app = typer.Typer(
    name="twincell",
    help="Correlate a virtual robot cell with the real one by 3D surface matching.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        typer.echo(f"twincell {version('twincell')}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version."),
    ] = False,
) -> None:
    """twincell: surface matching for robot cells."""


app.command("check")(check)
app.command("model")(model)
app.command("register")(register)
app.command("prepare")(prepare)
app.command("run")(run)
app.command("execute")(execute)
app.command("serve")(serve)
app.command("rapid")(rapid)
app.command("campaign")(campaign)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script: the command's exit status (see
    scenarios.cli.exit_status)."""
    return run_command_line(app, argv)


if __name__ == "__main__":
    sys.exit(main())
