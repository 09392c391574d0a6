"""The `twincell` command line: run, register, model, check, campaign (scenarios.cli.app)."""


def main(argv: list[str] | None = None) -> int:
    """The `twincell` console script (pyproject's [project.scripts]): scenarios.cli.app's
    main, imported when called, so that `python -m scenarios.cli.app` runs a module that
    importing this package did not import before."""
    from scenarios.cli.app import main as twincell

    return twincell(argv)
