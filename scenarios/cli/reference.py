"""The `twincell` command as a click command, for the documentation's command reference
(mkdocs-click reads its commands, options and help from it, so the page cannot drift)."""

from __future__ import annotations

import typer.main

from scenarios.cli.app import app

command = typer.main.get_command(app)
