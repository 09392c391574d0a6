"""The `twincell` command line: the typer app, assembled from one module per command
(scenarios.cli.*_command), and its entry point. Each command imports what it needs when it
runs, so that `twincell --help` stays fast."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Annotated, Any

import typer

from scenarios.cli import (
    author_command,
    campaign_command,
    check_command,
    connect_command,
    execute_command,
    model_command,
    prepare_command,
    rapid_command,
    register_command,
    run_command,
    serve_command,
    shift_command,
)
from scenarios.cli.exit_status import run_command_line
from scenarios.cli.help_format import TwincellCommand, TwincellGroup, example

app = typer.Typer(
    name="twincell",
    help="Correlate a virtual robot cell with the real one by 3D surface matching.",
    cls=TwincellGroup,
    # The help's paragraphs are Markdown: they wrap to the terminal, whatever the docstrings'
    # line breaks.
    rich_markup_mode="markdown",
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


#: The commands in the order `twincell --help` lists them: name, function, examples.
COMMANDS: tuple[tuple[str, Callable[..., Any], tuple[str, ...]], ...] = (
    ("check", check_command.check, check_command.EXAMPLES),
    ("model", model_command.model, model_command.EXAMPLES),
    ("register", register_command.register, register_command.EXAMPLES),
    ("prepare", prepare_command.prepare, prepare_command.EXAMPLES),
    ("run", run_command.run, run_command.EXAMPLES),
    ("execute", execute_command.execute, execute_command.EXAMPLES),
    ("serve", serve_command.serve, serve_command.EXAMPLES),
    ("connect", connect_command.connect, connect_command.EXAMPLES),
    ("author", author_command.author, author_command.EXAMPLES),
    ("rapid", rapid_command.rapid, rapid_command.EXAMPLES),
    ("campaign", campaign_command.campaign, campaign_command.EXAMPLES),
    ("shift", shift_command.shift, shift_command.EXAMPLES),
)
for command_name, function, examples in COMMANDS:
    app.command(command_name, cls=TwincellCommand, epilog=example(*examples))(function)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script: the command's exit status (see
    scenarios.cli.exit_status)."""
    return run_command_line(app, argv)


if __name__ == "__main__":
    sys.exit(main())
