"""Every command in the README and the documentation runs, so that a renamed option, key or
file fails here instead of at a user's.

A command is a line of a ```bash block (continuations joined, comments dropped); each one
is checked in the fast tier without running it: a `twincell` command parses under the real
command (its subcommand, arguments, options and their choices, the paths it takes as the
page's commands find them: MADE), a job's `--set`, `--fault`, `--cell`, `--model` and
`--program` make a configuration the job accepts, a campaign's `--vary` keys a campaign it
plans; a `python` script exists and takes the options given; a `pip install` names extras of
pyproject.toml; a `cd` names a folder.

Then every page's commands run as written, in order, from a scratch folder that holds the
repository's `examples/`, `tests/` and `bench/` (the quick pages in the fast tier, the pages
that run jobs in the slow tier), with three changes a test needs: a campaign's `--trials N`
runs 1 trial (the same machinery as for N), `rerun FILE` (the viewer; bench/viewer_check.py
looks at it where a display is) checks that the file is there, and `twincell serve` is
started in the background while the page's Python runs against it, then stopped with
SIGINT. A job a page runs must complete within its goals (the pages say they do). The page's
```python blocks run after its commands where they are whole programs (RUN_PYTHON). What no
page can run here is named in ELSEWHERE with the test that runs it.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import select
import shlex
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: The folders of the repository a page's commands name, linked into the scratch folder.
LINKED = ("examples", "tests", "bench")
#: Pages whose commands take seconds: run in the fast tier; the others in the slow tier. The
#: README's commands are the tutorials' own: it runs those no tutorial has.
FAST_PAGES = ("README.md", "docs/tutorials/scans.md", "docs/tutorials/check.md")
#: Pages whose ```python blocks are whole programs, run after the page's commands.
RUN_PYTHON = ("docs/tutorials/scans.md", "docs/tutorials/serve.md")
#: Commands no page runs here, and the test that runs them.
ELSEWHERE = {
    "pytest -q": ".ci/run: the fast tier itself",
    "cd examples/my_cell && pytest -n 2": "tests/test_example_my_cell.py",
    "dask scheduler": "tests/test_campaign_cluster.py: a Dask cluster of its own",
    "dask worker tcp://HEAD:8786 --nthreads 1": "tests/test_campaign_cluster.py",
    "twincell campaign skull --trials 1000 --backend dask --scheduler tcp://HEAD:8786":
        "tests/test_campaign_cluster.py",
    "mkdocs build --strict": ".ci/run",
    "twincell serve skull --speed 10 --egm-port 6510 --profiles 6511":
        "tests/test_controller_client.py: the twin in a process of its own, free ports",
    "twincell run skull --controller http://127.0.0.1:8080 --egm-port 6510 --profiles "
    "127.0.0.1:6511": "tests/test_controller_client.py: a job across the network",
    "twincell connect http://192.168.125.1:80 --egm-port 6510": "tests/test_controller_connect"
        ".py: no IRC5 here; the twin, and what it lacks",
    "twincell connect http://127.0.0.1:8080 --egm-port 6510": "tests/test_controller_connect"
        ".py: the twin served in process",
    "twincell run skull --calibration runs/latest/calibration.json": "tests/test_saved_"
        "calibration.py: the same job from the calibration of the one before it, its check and "
        "its cell time",
    "twincell shift skull --jobs 12 --hours 4": "tests/test_shift.py: a shift of 3 jobs over an "
        "hour, its goals, its calibrations, its files and its recording",
    "twincell campaign skull --stage shift --trials 20 --vary shift.policy=check,once,every "
    "--workers 2": "tests/test_campaign_shift.py: two policies, two jobs each, on one cell",
    "twincell run skull --cell point_laser": "tests/test_point_laser.py: the same job (without "
        "its recording), its goals, calibration and rasters checked against the truth",
    "twincell serve skull --cell point_laser --speed 10 --egm-port 6510 --laser-latency 8":
        "tests/test_analog_laser.py: the same cell served in a process of its own, free ports",
    "twincell run skull --cell point_laser --controller http://127.0.0.1:8080 --egm-port 6510":
        "tests/test_analog_laser.py: the latency and a raster through the network against "
        "the same in process; the whole job: bench/bench_network_job.py --cell point_laser",
}  # fmt: skip


@dataclass(frozen=True)
class Command:
    page: str  # relative to the repository
    line: int
    text: str

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.text}"


def _blocks(page: Path, language: str) -> list[tuple[int, str]]:
    text = page.read_text()
    found = re.finditer(rf"^```{language}\n(.*?)^```", text, re.MULTILINE | re.DOTALL)
    return [(text.count("\n", 0, m.start()) + 2, m.group(1)) for m in found]


def page_commands(page: Path) -> list[Command]:
    name = str(page.relative_to(ROOT))
    commands = []
    for first, block in _blocks(page, "bash"):
        pending, start = "", first
        for offset, raw in enumerate(block.splitlines()):
            if not pending:
                start = first + offset
            pending += raw.rstrip("\\").rstrip() + " " if raw.endswith("\\") else raw
            if raw.endswith("\\"):
                continue
            text = re.sub(r"(^|\s+)#.*$", "", pending).strip()  # a comment to the line's end
            if text:
                commands.append(Command(name, start, " ".join(text.split())))
            pending = ""
    return commands


ALL = [c for page in PAGES for c in page_commands(page)]


def _parts(command: Command) -> list[list[str]]:
    """The simple commands of a line joined by &&."""
    return [shlex.split(part) for part in command.text.split(" && ")]


def test_the_pages_have_commands() -> None:
    pages = {c.page for c in ALL}
    assert "README.md" in pages and len(pages) >= 8, pages
    assert all(Path(c.page).suffix == ".md" for c in ALL)


@pytest.mark.parametrize("command", ALL, ids=str)
def test_command_is_valid(command: Command) -> None:
    for words in _parts(command):
        check = CHECKS.get(words[0])
        assert check is not None, f"{command}: no check for {words[0]!r}: add one"
        check(words, command)


#: Paths a page's `twincell` command takes that an earlier command of the page makes (the
#: options check that a path they take exists): the path, whether it is a folder, and the
#: command that makes it.
MADE = {
    "dragon.twm": (False, "twincell prepare"),
    "runs/latest": (True, "twincell run"),
    "runs/latest/calibration.json": (False, "twincell run"),
    "ct/phantom_ct.nii.gz": (False, "python examples/make_ct.py"),
    "ct/plan.json": (False, "python examples/make_ct.py"),
    "my_touches.mod": (False, "twincell author"),
}


@contextlib.contextmanager
def _page_folder(command: Command) -> Iterator[None]:
    """In a scratch folder as the page's commands find it: the repository's folders they name
    (LINKED), and what the page's commands up to this one made (MADE), as empty stand-ins."""
    before = " && ".join(c.text for c in ALL if c.page == command.page and c.line <= command.line)
    with tempfile.TemporaryDirectory() as scratch:
        folder = _scratch(Path(scratch))
        for path, (is_folder, maker) in MADE.items():
            if maker in before:
                made = folder / path
                made.parent.mkdir(parents=True, exist_ok=True)
                if is_folder:
                    made.mkdir()
                else:
                    made.touch()
        with contextlib.chdir(folder):
            yield


def _check_twincell(words: list[str], command: Command) -> None:
    from typer import TyperException  # typer's own click's exceptions derive from it

    from scenarios.cli.reference import command as cli

    try:
        with _page_folder(command):
            context = cli.make_context("twincell", words[1:], resilient_parsing=False)
            sub = cli.get_command(context, words[1])
            assert sub is not None, f"{command}: no subcommand {words[1]!r}"
            sub_context = sub.make_context(words[1], words[2:], parent=context)
    except TyperException as exc:
        message: Any = exc  # a click exception, which formats its own message
        pytest.fail(f"{command}: {message.format_message()}")
    params = sub_context.params
    if words[1] == "run":
        _check_job(params, command)
    elif words[1] == "campaign":
        from scenarios.campaign import plan_campaign

        name, vary = _repo_path(params["name"]), params["vary"] or []
        plan_campaign(name, stage=params["stage"], trials=params["trials"], vary=vary,
                      seed=params["seed"])  # fmt: skip


def _repo_path(name: str) -> str:
    """A page's file argument as the repository holds it (a shipped name stays a name)."""
    return str(ROOT / name) if (ROOT / name).exists() else name


def _check_job(params: dict[str, Any], command: Command) -> None:
    from scenarios.cli.run_command import run_overrides
    from scenarios.configuration.config_files import load_config

    options = ("model", "units", "targets", "program", "assign", "fault")
    overrides = run_overrides(**{name: params[name] for name in options})
    cell = params["cell"]
    load_config(_repo_path(params["name"]), overrides,
                cell=_repo_path(cell) if cell is not None else None)  # fmt: skip


def _check_python(words: list[str], command: Command) -> None:
    script = ROOT / words[1]
    assert script.is_file(), f"{command}: no script {words[1]}"
    options = [w.split("=")[0] for w in words[2:] if w.startswith("--")]
    if options:  # asked in a folder of its own: a script's --help writes nothing anywhere
        with tempfile.TemporaryDirectory() as scratch:
            shown = subprocess.run([sys.executable, str(script), "--help"], capture_output=True,
                                   text=True, cwd=scratch, timeout=120).stdout  # fmt: skip
        missing = [o for o in options if o not in shown]
        assert not missing, f"{command}: {script.name} takes no {missing}"


def _check_pip(words: list[str], command: Command) -> None:
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = set(project["optional-dependencies"])
    for word in words[2:]:
        named = re.fullmatch(r"-e|\.(?:\[(\w+)\])?", word)
        assert named is not None, f"{command}: install the project, not {word!r}"
        assert named.group(1) in {None, *extras}, f"{command}: no extra {named.group(1)!r}"


def _check_cd(words: list[str], command: Command) -> None:
    assert (ROOT / words[1]).is_dir(), f"{command}: no folder {words[1]}"


def _check_elsewhere(words: list[str], command: Command) -> None:
    part = " ".join(words)
    assert part in ELSEWHERE or command.text in ELSEWHERE, (
        f"{command}: say in ELSEWHERE which test runs {part!r}"
    )


def _check_rerun(words: list[str], command: Command) -> None:
    assert len(words) == 2 and words[1].endswith(".rrd"), f"{command}: rerun FILE.rrd"


CHECKS = {
    "twincell": _check_twincell,
    "python": _check_python,
    "pip": _check_pip,
    "cd": _check_cd,
    "pytest": _check_elsewhere,
    "dask": _check_elsewhere,
    "mkdocs": _check_elsewhere,
    "rerun": _check_rerun,
}


def test_the_tests_named_elsewhere_exist() -> None:
    for where in ELSEWHERE.values():
        path = where.split(":")[0]
        assert (ROOT / path).exists(), where
    stale = set(ELSEWHERE) - {c.text for c in ALL} - {p for c in ALL for p in c.text.split(" && ")}
    assert not stale, f"ELSEWHERE names commands no page has: {stale}"


# Running the pages' commands.


def _scratch(tmp_path: Path) -> Path:
    for name in LINKED:
        (tmp_path / name).symlink_to(ROOT / name)
    return tmp_path


def _as_run(text: str) -> str:
    """The command as the test runs it (the module's docstring says what changes)."""
    text = re.sub(r"--trials \d+", "--trials 1", text)
    return re.sub(r"^rerun (\S+)$", r"test -f \1", text)


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


def _run_elsewhere(page: str) -> set[str]:
    """The simple commands that another page runs (for the README: the tutorials')."""
    if page != "README.md":
        return set()
    return {part for c in ALL if c.page != page for part in c.text.split(" && ")}


def run_page(page: str, folder: Path) -> None:
    serving: subprocess.Popen[str] | None = None
    elsewhere = _run_elsewhere(page)
    try:
        for command in page_commands(ROOT / page):
            # The installation is the test's own; a command another test runs is left to it.
            parts = [p for p in command.text.split(" && ") if not p.startswith("pip install")]
            if command.text in ELSEWHERE or all(p in elsewhere | set(ELSEWHERE) for p in parts):
                continue
            command = Command(command.page, command.line, " && ".join(parts))
            if command.text.startswith("twincell serve"):
                serving = _serve(command, folder)
                continue
            done = subprocess.run(["bash", "-c", _as_run(command.text)], cwd=folder, env=_env(),
                                  capture_output=True, text=True, timeout=900)  # fmt: skip
            # Exit status 6: the program ran and the run says its goal is at risk, which the
            # page must say too.
            at_risk = done.returncode == 6 and "at risk" in (ROOT / page).read_text()
            assert done.returncode == 0 or at_risk, (
                f"{command}: exit {done.returncode}\n{done.stderr[-3000:]}"
            )
            if any(p.startswith("twincell run ") for p in parts):
                _assert_goals(command, (folder / "runs" / "latest").resolve(), at_risk)
        if page in FIGURES:
            FIGURES[page](folder)
        if page in RUN_PYTHON:
            for line, code in _blocks(ROOT / page, "python"):
                done = subprocess.run([sys.executable, "-c", code], cwd=folder, env=_env(),
                                      capture_output=True, text=True, timeout=600)  # fmt: skip
                assert done.returncode == 0, f"{page}:{line}: the Python block\n{done.stderr}"
    finally:
        if serving is not None:
            _stop(serving)


def _assert_goals(command: Command, folder: Path, at_risk: bool = False) -> None:
    """A job a page runs completes within its goals, as the page says it does (`at_risk`:
    the run said its goal was at risk, as the page does: its goals are still checked)."""
    from scenarios.results.results_file import read_results
    from scenarios.testing import assert_goals
    from scenarios.testing.runs import JobRun

    if "checks" not in json.loads((folder / "results.json").read_text()):
        return  # the seed paper's experiments: a table of matches, no goals
    result = read_results(folder)
    if at_risk:
        missed = [name for name, goal in result.checks.items() if not goal.met]
        assert result.status == "at_risk" and not missed, f"{command}: {result.reason}; {missed}"
        return
    try:
        assert_goals(JobRun(result, folder))
    except AssertionError as exc:
        pytest.fail(f"{command}: {exc}")


# The served twin starts with SIGINT at its default whatever this process inherited (a
# shell's background job ignores SIGINT, and so would its children), as a user's Ctrl-C finds
# it in a terminal.
RESET_SIGINT = (
    "import os, signal, sys\n"
    "signal.signal(signal.SIGINT, signal.SIG_DFL)\n"
    "os.execvp(sys.argv[1], sys.argv[1:])\n"
)


def _serve(command: Command, folder: Path) -> subprocess.Popen[str]:
    argv = [sys.executable, "-c", RESET_SIGINT, *shlex.split(command.text)]
    process = subprocess.Popen(argv, cwd=folder, env=_env(), text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    assert process.stdout is not None and process.stderr is not None
    ready, _, _ = select.select([process.stdout], [], [], 300.0)  # the cell built, served
    line = process.stdout.readline() if ready else ""  # "serving http://... (Ctrl-C to stop)"
    if not line.startswith("serving "):
        process.kill()
        pytest.fail(f"{command}: {line}{process.communicate(timeout=60)[1]}")
    return process


def _stop(process: subprocess.Popen[str]) -> None:
    """Ctrl-C stops the served twin within a minute; one that does not is killed, not left
    holding its port."""
    process.send_signal(signal.SIGINT)
    try:
        out, err = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        pytest.fail("twincell serve did not stop within 60 s of SIGINT; killed")
    assert process.returncode == 0, err
    assert "stopped;" in out, out


# The figures a page prints, against what its own commands just made.


def _text_block(page: str, starts: str) -> str:
    return next(b for _, b in _blocks(ROOT / page, "text") if b.startswith(starts))


def _scans_figures(folder: Path) -> None:
    """docs/tutorials/scans.md shows the dragon's match: its first rows of T_model_data and
    its RMS, as `twincell register` printed them (6 and 4 decimals)."""
    shown = _text_block("docs/tutorials/scans.md", "T_model_data")
    result = json.loads((folder / "result.json").read_text())
    rows = [[float(v) for v in line.strip(" [].").split()] for line in shown.splitlines()[1:3]]
    made = [v for row in result["T_model_data"][:2] for v in row]
    assert [v for row in rows for v in row] == pytest.approx(made, abs=2e-6), (rows, made)
    rms_mm = float(re.search(r"rms \[mm\]\s+│ ([\d.]+)", shown).group(1))  # type: ignore[union-attr]
    assert rms_mm == pytest.approx(result["rms"] * 1e3, abs=1e-4)


def _skull_figures(folder: Path) -> None:
    """docs/tutorials/skull-job.md shows seed 0's table: each target's error, registration
    share, predicted TRE and error budget's bound [mm], to the printed 0.001 mm."""
    shown = _text_block("docs/tutorials/skull-job.md", "                          skull run")
    (run,) = (folder / "runs").glob("skull-*")  # the page runs the skull job once here
    results = json.loads((run / "results.json").read_text())
    by_name = {t["name"]: t for t in results["targets"]}
    bounds = {t["name"]: t["bound_m"] for t in results["budget"]["targets"]}
    row = (
        r"│ (\w+): error / reg\. share / pred\. TRE / budget \[mm\]\s+│ "
        r"([\d.]+) / ([\d.]+) / ([\d.]+) / ([\d.]+)"
    )
    rows = re.findall(row, shown)
    assert len(rows) == len(by_name) == 4, rows
    for name, error, share, tre, bound in rows:
        fresh = by_name[name]
        made = [fresh["error_m"], fresh["registration_error_m"], fresh["predicted_tre_m"]]
        made.append(bounds[name])
        assert [float(error), float(share), float(tre), float(bound)] == pytest.approx(
            [1e3 * v for v in made], abs=6e-4
        ), (name, made)


def _ct_figures(folder: Path) -> None:
    """docs/tutorials/ct.md gives the run on the CT's files, seed 0: its RMS and largest
    target error [mm], to the printed 0.01 mm."""
    text = (ROOT / "docs/tutorials/ct.md").read_text()
    found = re.search(r"target errors ([\d.]+) mm RMS, ([\d.]+) mm at most", " ".join(text.split()))
    assert found is not None
    runs = [p.parent for p in (folder / "runs").glob("skull-*/config.yaml")
            if "phantom_ct.nii.gz" in p.read_text()]  # fmt: skip
    assert len(runs) == 1, runs
    results = json.loads((runs[0] / "results.json").read_text())
    made = [results["target_error_rms_m"] * 1e3, results["target_error_max_m"] * 1e3]
    assert [float(found.group(1)), float(found.group(2))] == pytest.approx(made, abs=0.006)


FIGURES = {
    "docs/tutorials/scans.md": _scans_figures,
    "docs/tutorials/skull-job.md": _skull_figures,
    "docs/tutorials/ct.md": _ct_figures,
}


@pytest.mark.parametrize("page", FAST_PAGES)
def test_quick_page_runs(page: str, tmp_path: Path) -> None:
    run_page(page, _scratch(tmp_path))


#: docs/index.md installs and builds the documentation (.ci/run does); docs/benchmarks.md's
#: scripts run in their short form in tests/test_bench.py.
SLOW_PAGES = sorted(
    {c.page for c in ALL} - set(FAST_PAGES) - {"docs/index.md", "docs/benchmarks.md"}
)


@pytest.mark.slow
@pytest.mark.parametrize("page", SLOW_PAGES)
def test_page_runs(page: str, tmp_path: Path) -> None:
    run_page(page, _scratch(tmp_path))


@pytest.mark.parametrize(
    "text",
    [
        "twincell run skull --no-such-option",  # an option renamed
        "twincell run skull --set cell.noise.laser_sigma=2e-4",  # a key renamed
        "twincell run skull --cell no_such_cell",  # a cell that is not there
        "twincell campaign skull --vary cell.noise.no_such_key=1,2",  # a campaign's key
        "twincell registr scan.ply model.ply",  # a subcommand misspelt
        "python bench/bench_cell.py --no-such-option",  # a script's option
        'pip install -e ".[no_such_extra]"',  # an extra
    ],
)
def test_a_stale_command_fails_its_check(text: str) -> None:
    command = Command("a page", 1, text)
    with pytest.raises((pytest.fail.Exception, AssertionError, ValueError)):
        for words in _parts(command):
            CHECKS[words[0]](words, command)
