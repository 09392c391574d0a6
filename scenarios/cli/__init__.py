"""The `twincell` command line: run, register, model, check, campaign."""

from scenarios.cli.app import main

__all__ = ["main"]
