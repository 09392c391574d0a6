"""The command line's contract: version, help, user errors as one line and exit status 2, paths
checked by the options that take them."""

from __future__ import annotations

import os
import shlex
from importlib.metadata import version
from pathlib import Path
from typing import Any

import pytest

from scenarios.cli.app import main

ROOT = Path(__file__).resolve().parent.parent


def test_version_prints_the_installed_version(capsys) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"twincell {version('twincell')}"


def test_unknown_command_is_a_usage_error(capsys) -> None:
    assert main(["no-such-command"]) == 2
    assert "no-such-command" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["register", "{data}", "{tmp}/nope.twm"], "'MODEL': file '{tmp}/nope.twm' does not exist"),
        (["register", "{data}", "{tmp}"], "'MODEL': file '{tmp}' is a directory"),
        (["register", "{data}", "{model}", "--targets", "{tmp}/t.json"],
         "'--targets': file '{tmp}/t.json' does not exist"),
        (["register", "{data}", "{model}", "--init", "{tmp}/p.txt"],
         "'--init': file '{tmp}/p.txt' does not exist"),
        (["prepare", "{tmp}/nope.stl"], "'MODEL': file '{tmp}/nope.stl' does not exist"),
        (["run", "skull", "--model", "{tmp}/nope.stl"],
         "'--model': path '{tmp}/nope.stl' does not exist"),
        (["run", "skull", "--targets", "{tmp}"], "'--targets': file '{tmp}' is a directory"),
        (["run", "skull", "--program", "{tmp}/nope.mod"],
         "'--program': path '{tmp}/nope.mod' does not exist"),
        (["execute", "{tmp}/nope"], "'RUN_FOLDER': dir '{tmp}/nope' does not exist"),
        (["execute", "{model}"], "'RUN_FOLDER': dir '{model}' is a file"),
        (["rapid", "{tmp}/nope.mod"], "'PATH...': path '{tmp}/nope.mod' does not exist"),
    ],
)  # fmt: skip
def test_a_path_is_checked_by_its_option(args, named, tmp_path, capsys) -> None:
    """A path the command needs is checked by the option (or argument) that takes it, before
    the command runs: a usage error naming the option and the path, exit status 2."""
    data = ROOT / "tests/data/stanford/dragon/scan_stand000.ply"
    model = ROOT / "tests/data/stanford/dragon/model.ply"
    fill = {"{tmp}": str(tmp_path), "{data}": str(data), "{model}": str(model)}

    def filled(text: str) -> str:
        for key, value in fill.items():
            text = text.replace(key, value)
        return text

    assert main([filled(a) for a in args]) == 2
    err = " ".join(capsys.readouterr().err.split())  # as one line, whatever the width
    assert f"Invalid value for {filled(named)}" in err, err
    assert not list(tmp_path.iterdir())  # nothing ran


#: The files the commands' examples take that are a user's own (the others are the
#: repository's), made as empty stand-ins where the examples are parsed.
USERS_FILES = {"model.stl": False, "model.twm": False, "runs/latest": True}


def test_each_command_has_a_summary_and_examples_that_parse(tmp_path, monkeypatch) -> None:
    """`twincell --help` gives each command in one line (the help's first paragraph, within
    the 66 columns the commands' panel gives it at 80), and each command's help ends with
    examples that parse under the command, the repository's files and the user's found."""
    from typer import TyperException

    from scenarios.cli.app import COMMANDS
    from scenarios.cli.reference import command as cli

    for name in ("examples", "tests"):
        (tmp_path / name).symlink_to(ROOT / name)
    for path, is_folder in USERS_FILES.items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        if is_folder:
            (tmp_path / path).mkdir()
        else:
            (tmp_path / path).touch()
    monkeypatch.chdir(tmp_path)
    assert list(cli.commands) == [name for name, _, _ in COMMANDS]
    for name, _, examples in COMMANDS:
        sub = cli.commands[name]
        summary = (sub.help or "").split("\n\n")[0]
        assert "\n" not in summary and 0 < len(summary) <= 66, (name, summary)
        assert examples and sub.epilog is not None, name
        for line in examples:
            assert f"`{line}`" in sub.epilog, (name, line)
            words = shlex.split(line)
            assert words[:2] == ["twincell", name], line
            try:
                sub.make_context(name, words[2:])
            except TyperException as exc:
                message: Any = exc  # a click exception, which formats its own message
                pytest.fail(f"{line}: {message.format_message()}")


def test_no_cache_is_a_run_option_not_the_environment(tmp_path, monkeypatch) -> None:
    """`twincell run --no-cache` tells the run (RunOptions.cache), and leaves the process's
    environment as it was."""
    from scenarios.jobs import runner

    monkeypatch.delenv("TWINCELL_NO_CACHE", raising=False)
    told: list[runner.RunOptions | None] = []

    class Experiments:  # what the seed paper's experiments return: a table
        table = "a table"

    def run_job(name: str, **kwargs: Any) -> tuple[Path, Experiments]:
        told.append(kwargs["options"])
        return tmp_path, Experiments()

    monkeypatch.setattr(runner, "run_job", run_job)
    assert main(["run", "paper", "--no-cache", "--quiet"]) == 0
    assert main(["run", "paper", "--quiet"]) == 0
    assert [options.cache for options in told if options is not None] == [False, True]
    assert "TWINCELL_NO_CACHE" not in os.environ


def test_serve_takes_the_users_cell_and_settings(capsys) -> None:
    # The cell is applied before anything is served: a cell whose arm runs no RAPID is
    # refused in one line, naming the arm; an unknown key in --set names the key.
    assert main(["serve", "skull", "--cell", "ur5", "--quiet"]) == 2
    assert "the job's arm, the ur5, does not run RAPID" in capsys.readouterr().err
    assert main(["serve", "skull", "--set", "cell.no_such_key=1", "--quiet"]) == 2
    assert "no_such_key" in capsys.readouterr().err
