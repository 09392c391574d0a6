"""The command line's contract: version, help, user errors as one line and exit status 2."""

from __future__ import annotations

from importlib.metadata import version

from scenarios.cli.app import main


def test_version_prints_the_installed_version(capsys) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"twincell {version('twincell')}"


def test_unknown_command_is_a_usage_error(capsys) -> None:
    assert main(["no-such-command"]) == 2
    assert "no-such-command" in capsys.readouterr().err
