"""How the `twincell` command ends: its exit status, and the one line that says why when it
is not 0 (a user's error, an unexpected warning, an interrupted run)."""

from __future__ import annotations

import sys
from typing import Any

import typer

from scenarios.scenario_errors import is_user_error


def run_command_line(app: typer.Typer, argv: list[str] | None = None) -> int:
    """Run the command line `app` on `argv` (default: the process's arguments) and return its
    exit status: user errors become one line and exit status 2.

    A numerical warning (numpy's RuntimeWarning) or one of the project's own is a bug: it is
    raised as an error, reported in one line (exit status 1), never printed as a warning.
    A run stopped by SIGINT or SIGTERM is one line too (where it stopped, its run folder),
    exit status 130 or 143 as a shell reports a process killed by the signal.
    """
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            for package in ("registration", "scenarios", "cell", "models"):
                warnings.filterwarnings("error", module=package)
            status = app(args=argv, standalone_mode=False)
        if isinstance(status, int):  # click returns typer.Exit's code without standalone mode
            return status
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except typer.Abort:
        typer.echo("twincell: aborted", err=True)
        return 130
    except typer.TyperException as exc:  # usage errors: typer prints them the click way
        click_error: Any = exc  # typer's exceptions are click's, which show themselves
        click_error.show()
        return int(getattr(exc, "exit_code", 2))
    except Warning as exc:
        typer.echo(f"twincell: internal error (an unexpected warning): {exc}", err=True)
        return 1
    except Exception as exc:
        if is_user_error(exc):
            typer.echo(f"twincell: error: {exc}", err=True)
            return 2
        raise
    except BaseException as exc:
        if "scenarios.jobs.interrupt" not in sys.modules:  # no run: nothing to interrupt
            raise
        from scenarios.jobs.interrupt import RunInterrupted

        if not isinstance(exc, RunInterrupted):
            raise
        typer.echo(f"twincell: {exc}", err=True)
        return exc.exit_status
    return 0
