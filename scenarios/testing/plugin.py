"""twincell's pytest plugin (entry point `pytest11`): end-to-end tests of the user's own cell.

Fixtures (each but `twincell_seed` is a function the test calls):
- `run_job`: a function `run_job(config, seed=None, program=None, overrides=None, cell=None)
  -> JobRun` that runs a job (a shipped job's name or a configuration file, found beside the
  test file too) into a run folder of the test's own and returns its `JobRun` (the typed
  result and the folder);
- `real_cell`: a function `real_cell(config, seed=None, overrides=None, cell=None) -> JobCell`
  that builds the job's real cell (the same seed: the same arm, errors and true placement as
  the run), its controller ready;
- `served_twin`: a function `served_twin(config_or_run_folder, seed=None, speed=1.0,
  egm_port=None, overrides=None, cell=None) -> Serving` that serves the job's cell (in
  `cell`, like `run_job`'s) on RWS (a free port; `.url`) and EGM, closed after the test;
- `twincell_seed`: the seed (an int); a test that asks for it runs once per seed:
  `--twincell-seeds N`, else the `twincell_seeds(n, start=0)` marker's n, else 1 (each seed
  its own test, so that pytest-xdist spreads them over the workers: `pytest -n auto`).

A configuration the project refuses, a program the reader refuses, a model that does not
load: the fixture fails the test with the project's one-line error. Run folders of failed
tests are kept and listed at the end of the session with the command to look at them; those
of passed tests are removed unless `--twincell-keep`. Recordings (run.rrd) are written unless
`--twincell-no-rrd`. In a pytest-xdist worker the numeric libraries' thread pools keep to
the worker's share of the cores (scenarios.workers). The pipeline is imported by the
fixtures that run it, not by loading the plugin.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from scenarios.jobs.serve import Serving
    from scenarios.realcell.setup import JobCell
    from scenarios.testing.runs import JobRun

_FOLDERS = pytest.StashKey[list[Path]]()
_OUTCOME = pytest.StashKey[str]()
_PROPERTY = "twincell_run_folders"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("twincell", "twincell end-to-end cell tests")
    group.addoption("--twincell-seeds", type=int, default=None, metavar="N",
                    help="run each test that asks for twincell_seed over N seeds (from its "
                    "twincell_seeds marker's start, else 0)")  # fmt: skip
    group.addoption("--twincell-out", default=None, metavar="DIR",
                    help="where the runs' folders go (default: pytest's temporary "
                    "folder)")  # fmt: skip
    group.addoption("--twincell-no-rrd", action="store_true",
                    help="write no recording (run.rrd) in the runs: faster")  # fmt: skip
    group.addoption("--twincell-keep", action="store_true",
                    help="keep the run folders of passed tests too")  # fmt: skip


def pytest_configure(config: pytest.Config) -> None:
    workerinput = getattr(config, "workerinput", None)
    if workerinput is not None:  # a pytest-xdist worker: its share of the machine's cores
        from scenarios.workers import share_cores

        share_cores(int(workerinput.get("workercount", 1)))
    config.addinivalue_line(
        "markers",
        "twincell_seeds(n, start=0): run the test once per seed start..start+n-1 "
        "(its twincell_seed fixture); --twincell-seeds N overrides n",
    )


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "twincell_seed" not in metafunc.fixturenames:
        return
    marker = metafunc.definition.get_closest_marker("twincell_seeds")
    n, start = 1, 0
    if marker is not None:
        n = int(marker.args[0] if marker.args else marker.kwargs.get("n", 1))
        start = int(marker.args[1] if len(marker.args) > 1 else marker.kwargs.get("start", 0))
    option = metafunc.config.getoption("--twincell-seeds")
    if option is not None:
        n = option
    if n < 1:
        raise pytest.UsageError(f"twincell seeds: {n}; give at least 1")
    seeds = list(range(start, start + n))
    metafunc.parametrize("twincell_seed", seeds, ids=[f"seed{s}" for s in seeds])


@pytest.fixture
def twincell_seed(request: pytest.FixtureRequest) -> int:
    """The real cell's seed of this test (see pytest_generate_tests)."""
    return int(request.param)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Any:
    report = yield
    if report.failed:
        item.stash[_OUTCOME] = "failed"
        folders = item.stash.get(_FOLDERS, [])
        if folders:
            report.user_properties.append((_PROPERTY, [str(f) for f in folders]))
    elif report.when == "call" and item.stash.get(_OUTCOME, "") != "failed":
        item.stash[_OUTCOME] = report.outcome
    return report


def pytest_terminal_summary(terminalreporter: Any) -> None:
    lines = []
    for report in terminalreporter.stats.get("failed", []):
        for name, folders in getattr(report, "user_properties", []):
            if name == _PROPERTY:
                for folder in folders:
                    rrd = Path(folder) / "run.rrd"
                    look = f"  (rerun {rrd})" if rrd.is_file() else ""
                    lines.append(f"{report.nodeid}: {folder}{look}")
    if lines:
        terminalreporter.section("twincell: run folders of the failed tests (kept)")
        for line in dict.fromkeys(lines):
            terminalreporter.write_line(line)


def _out(request: pytest.FixtureRequest) -> Path:
    given = request.config.getoption("--twincell-out")
    if given is not None:
        base = Path(given)
    else:
        base = request.getfixturevalue("tmp_path_factory").getbasetemp() / "twincell"
    name = re.sub(r"[^\w.-]+", "_", request.node.nodeid)[-120:]
    return base / name


def _found(path: str | Path, request: pytest.FixtureRequest) -> str | Path:
    """A file given relative to the test file, if it is there and not in the working folder."""
    candidate = Path(path)
    beside = Path(str(request.node.fspath)).parent / candidate
    if not candidate.is_absolute() and not candidate.exists() and beside.exists():
        return beside
    return path


def _fail_on_user_error(action: Callable[[], Any]) -> Any:
    from scenarios.scenario_errors import is_user_error

    try:
        return action()
    except Exception as exc:
        if not is_user_error(exc):
            raise
        message = f"twincell: error: {exc}"
    pytest.fail(message, pytrace=False)  # outside the handler: one line, no chained traceback


def _cleanup(request: pytest.FixtureRequest, folders: list[Path]) -> None:
    """Remove the run folders of a passed test (unless --twincell-keep), and a `latest` link
    beside them that then points nowhere."""
    outcome = request.node.stash.get(_OUTCOME, "failed")
    if outcome == "passed" and not request.config.getoption("--twincell-keep"):
        for folder in folders:
            shutil.rmtree(folder, ignore_errors=True)
            latest = folder.parent / "latest"
            if latest.is_symlink() and not latest.exists():
                latest.unlink(missing_ok=True)


@pytest.fixture
def run_job(request: pytest.FixtureRequest) -> Iterator[Callable[..., JobRun]]:
    """A function that runs a job and returns its run: `run_job(config, seed=None,
    program=None, overrides=None, cell=None) -> JobRun`. `config`: a shipped job's name or a
    job YAML; `seed`: the real cell's draw (default the job's); `program`: a RAPID module or
    task folder (operations.program); `overrides`: dotted keys as `twincell run --set` takes
    them; `cell`: a shipped cell's name or a cell YAML. Files are found beside the test file
    too. The run folders are removed after a passed test (unless --twincell-keep)."""
    folders: list[Path] = []
    request.node.stash[_FOLDERS] = folders

    def run(
        config: str | Path,
        seed: int | None = None,
        program: str | Path | None = None,
        overrides: dict[str, object] | None = None,
        cell: str | Path | None = None,
    ) -> JobRun:
        from scenarios.jobs.runner import RunOptions
        from scenarios.jobs.runner import run_job as run_one
        from scenarios.results.run import RunResult
        from scenarios.testing.runs import JobRun

        extra = dict(overrides or {})
        if program is not None:
            extra["operations.program"] = str(_found(program, request))
        rrd = not request.config.getoption("--twincell-no-rrd")
        folder, result = _fail_on_user_error(
            lambda: run_one(
                _found(config, request),
                seed=seed,
                out=_out(request),
                overrides=extra,
                options=RunOptions(rrd=rrd),
                cell=None if cell is None else _found(cell, request),
            )
        )
        folders.append(Path(folder))
        if not isinstance(result, RunResult):
            pytest.fail(f"twincell: {config}: the paper's experiments are not a cell job")
        return JobRun(result, Path(folder))

    yield run
    _cleanup(request, folders)


@pytest.fixture
def real_cell(request: pytest.FixtureRequest) -> Callable[..., JobCell]:
    """A function that builds a job's real cell: `real_cell(config, seed=None,
    overrides=None, cell=None) -> JobCell` (scenarios.realcell.setup: its `.controller`,
    ready, and `.evaluator`, the truth), as `twincell run` builds it for the seed."""

    def build(
        config: str | Path,
        seed: int | None = None,
        overrides: dict[str, object] | None = None,
        cell: str | Path | None = None,
    ) -> JobCell:
        from scenarios.jobs.serve import cell_of_job

        return _fail_on_user_error(
            lambda: cell_of_job(
                _found(config, request),
                seed,
                overrides,
                None if cell is None else _found(cell, request),
            )
        )

    return build


@pytest.fixture
def served_twin(request: pytest.FixtureRequest) -> Iterator[Callable[..., Serving]]:
    """A function that serves a job's cell as its controller: `served_twin(
    config_or_run_folder, seed=None, speed=1.0, egm_port=None, overrides=None, cell=None)
    -> Serving` (scenarios.jobs.serve: `.url` the RWS address on a free port, `.config` the
    job as served, `.wait_executions(n, timeout_s)` the programs measured against the
    truth); `speed`: the cell's time over the wall clock's. Every twin served is closed
    after the test."""
    served: list[Serving] = []

    def serve(
        config: str | Path,
        seed: int | None = None,
        speed: float = 1.0,
        egm_port: int | None = None,
        overrides: dict[str, object] | None = None,
        cell: str | Path | None = None,
    ) -> Serving:
        from scenarios.jobs.serve import serve_job
        from scenarios.twin.server import ServeOptions

        options = ServeOptions(port=0, egm_port=egm_port)
        serving = _fail_on_user_error(
            lambda: serve_job(
                str(_found(config, request)),
                options,
                seed=seed,
                speed=speed,
                out=_out(request),
                overrides=overrides,
                cell=None if cell is None else _found(cell, request),
            )
        )
        served.append(serving)
        return serving

    yield serve
    for serving in served:
        serving.close()
    _cleanup(request, [s.folder for s in served])
