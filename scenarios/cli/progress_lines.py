"""The progress lines that the long commands (run, execute, serve) print as they go."""

from __future__ import annotations

from collections.abc import Callable

import typer


def progress_lines(quiet: bool) -> Callable[[str], None]:
    """What a command says as it goes: each message indented on standard error, or nothing
    (--quiet)."""

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    return progress
