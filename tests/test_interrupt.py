"""A run stopped by SIGTERM or SIGINT in any stage: exit status 143 or 130 with one line,
results.json "incomplete" with the signal and the stage, no run.rrd, and every file in the
run folder complete (no partial file, no temporary one).

The end-to-end cases run the real `twincell run` in a subprocess, watch its progress lines
(or the files it writes) for the stage to begin, and send the signal there."""

from __future__ import annotations

import json
import os
import pickle
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml

from scenarios.cli.app import main
from scenarios.jobs import runner
from scenarios.jobs.interrupt import RunInterrupted, SignalGuard
from scenarios.jobs.stage_tracker import StageTracker
from scenarios.outputs.run_files import read_ply

TWINCELL = Path(sys.executable).with_name("twincell")  # the console script, as a user runs it
# The child starts with SIGINT and SIGTERM at their defaults whatever this process inherited
# (a shell's background job ignores SIGINT, and so would its children).
RESET_SIGNALS = (
    "import os, signal, sys\n"
    "for s in (signal.SIGINT, signal.SIGTERM):\n"
    "    signal.signal(s, signal.SIG_DFL)\n"
    "os.execv(sys.argv[1], sys.argv[1:])\n"
)


# -- the pieces, in this process ------------------------------------------------------------
def test_stage_tracker_starts_in_setup_and_follows_the_job() -> None:
    stages = StageTracker()
    assert stages.current == "setup"
    stages.enter("scan")
    stages.enter("register")
    assert stages.current == "register"
    with pytest.raises(ValueError, match="non-empty"):
        stages.enter(" ")


def test_run_interrupted_names_the_signal_and_its_exit_status() -> None:
    term = RunInterrupted("SIGTERM", "scan", "runs/skull-1")
    assert (term.reason, term.exit_status) == ("interrupted (SIGTERM)", 143)
    assert RunInterrupted("SIGINT").exit_status == 130
    assert str(term) == "interrupted (SIGTERM) during scan; run folder runs/skull-1"
    back = pickle.loads(pickle.dumps(term))  # crosses a process pool as it is
    assert (back.signal_name, back.stage, back.folder) == ("SIGTERM", "scan", "runs/skull-1")
    assert not isinstance(term, Exception)  # no `except Exception` swallows it
    with pytest.raises(ValueError, match="SIGINT, SIGTERM"):
        RunInterrupted("SIGHUP")


def test_signal_guard_raises_once_then_restores_the_handlers() -> None:
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with SignalGuard() as guard:
        with pytest.raises(RunInterrupted) as caught:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)  # the handler runs at the next bytecode; this is not reached
        assert caught.value.signal_name == "SIGTERM"
        os.kill(os.getpid(), signal.SIGINT)  # winding down: noted, not raised
        time.sleep(0.05)
        assert guard.received == "SIGTERM"
    assert {s: signal.getsignal(s) for s in before} == before


def test_signal_guard_does_nothing_outside_the_main_thread() -> None:
    installed: list[object] = []

    def in_thread() -> None:
        with SignalGuard():
            installed.append(signal.getsignal(signal.SIGTERM))

    before = signal.getsignal(signal.SIGTERM)
    thread = threading.Thread(target=in_thread)
    thread.start()
    thread.join()
    assert installed == [before]


def _fake_cell_job(stop: Callable[[], None], at: str) -> runner.Job:
    """A cell job that enters the pipeline's stages, writes a file in each, and calls
    `stop` in stage `at` after leaving a temporary file there (as a write that a signal
    cut short between its creation and its clean-up would)."""

    def job(config: Any, folder: Any, say: Any, options: Any, stages: StageTracker) -> Any:
        for name in ("calibrate", "scan", "register", "execute", "export"):
            stages.enter(name)
            folder.write_text(f"{name}.txt", name)
            if name == at:
                folder.file(f".{name}.txt.abc123.tmp").write_text("half")
                stop()
        return {"status": "complete"}

    return job


def _one_folder(out: Path) -> Path:
    (folder,) = [p for p in out.iterdir() if p.name != "latest"]
    return folder


def test_an_error_records_its_stage_and_leaves_no_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fail() -> None:
        raise OSError("disk full")

    monkeypatch.setitem(runner.JOBS, "cell", _fake_cell_job(fail, "register"))
    with pytest.raises(OSError, match="disk full"):
        runner.run_job("skull", out=tmp_path)
    folder = _one_folder(tmp_path)
    results = json.loads((folder / "results.json").read_text())
    assert results["status"] == "incomplete"
    assert (results["reason"], results["stage"]) == ("disk full", "register")
    names = sorted(p.name for p in folder.iterdir())
    assert names == ["calibrate.txt", "config.yaml", "register.txt", "results.json", "scan.txt"]


def test_sigterm_in_the_cli_is_exit_143_and_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def terminate() -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(1.0)

    handler = signal.getsignal(signal.SIGTERM)
    monkeypatch.setitem(runner.JOBS, "cell", _fake_cell_job(terminate, "execute"))
    assert main(["run", "skull", "--out", str(tmp_path), "--quiet"]) == 143
    assert signal.getsignal(signal.SIGTERM) == handler  # restored
    folder = _one_folder(tmp_path)
    err = capsys.readouterr().err
    assert err == f"twincell: interrupted (SIGTERM) during execute; run folder {folder}\n"
    results = json.loads((folder / "results.json").read_text())
    assert (results["reason"], results["stage"]) == ("interrupted (SIGTERM)", "execute")
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("moved", [False, True], ids=["closing", "closed"])
def test_a_stop_while_the_recording_closes_discards_it(
    moved: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The job is done and its recording is being kept (flushed, moved into place) when the
    signal lands: the run is incomplete, so neither run.rrd nor its partial file stays."""
    from scenarios.jobs import pipeline
    from scenarios.realcell.recording import Recording

    @dataclass(frozen=True)
    class Done:
        status: str = "complete"

    def job(
        config: Any,
        folder: Path,
        progress: Any,
        recording: Any,
        stages: Any,
        use_cache: bool,
        address: Any = None,
        commissioning: Any = None,
        calibration: Any = None,
    ) -> Done:
        stages.enter("export")
        return Done()

    close = Recording.close

    def close_then_stop(self: Recording, keep: bool = True) -> None:
        if keep and moved:
            close(self, keep=True)
            assert self.path.is_file()
        if keep:
            raise RunInterrupted("SIGTERM")
        close(self, keep=keep)

    monkeypatch.setattr(pipeline, "run_cell_job", job)
    monkeypatch.setattr(Recording, "close", close_then_stop)
    with pytest.raises(RunInterrupted):
        runner.run_job("skull", out=tmp_path, options=runner.RunOptions(rrd=True))
    folder = _one_folder(tmp_path)
    assert sorted(p.name for p in folder.iterdir()) == ["config.yaml", "results.json"]
    results = json.loads((folder / "results.json").read_text())
    assert (results["reason"], results["stage"]) == ("interrupted (SIGTERM)", "export")


# -- the real run, in a subprocess ----------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """Run `job` with `settings` and send `signal_name` `delay_s` after `marker` is seen: a
    progress line that starts with it, or a file of that name in the run folder."""

    job: str
    settings: tuple[str, ...]
    marker: str
    stage: str
    signal_name: str = "SIGTERM"
    marker_is_file: bool = False
    delay_s: float = 0.0


NO_CALIBRATION = ("calibration.enabled=false",)
CASES = {
    "setup": Case("skull", NO_CALIBRATION, "model 'skull': virtual and real entity", "setup"),
    "calibrate": Case(
        "skull", ("calibration.enabled=true",), "calibration: the laser views", "calibrate"
    ),
    "scan": Case("skull", NO_CALIBRATION, "scan pass 1", "scan"),
    # scan.ply is written as the scan ends, then the match runs (0.3 s or more).
    "register": Case("skull", NO_CALIBRATION, "scan.ply", "register", marker_is_file=True),
    # The verification re-scans a strip of the object (a second or more) right after the
    # pre-motion check.
    "verify": Case(
        "skull", NO_CALIBRATION, "check: the corrected program passes", "verify", delay_s=0.3
    ),
    # The verification's verdict, then the touches (0.7 s or more, silent until they end).
    "execute": Case("skull", NO_CALIBRATION, "verify: agrees", "execute", delay_s=0.2),
    "scan-sigint": Case("skull", NO_CALIBRATION, "scan pass 2", "scan", signal_name="SIGINT"),
    # The corrected program's files: targets.json first, program.mod and its run on the
    # nominal controller after.
    "export": Case("skull", NO_CALIBRATION, "targets.json", "export", marker_is_file=True),
}
# What a stage finds written before it; each must be complete.
WRITTEN_BEFORE = {
    "setup": set(),
    "calibrate": set(),
    "scan": set(),
    "register": {"scan.ply"},
    "verify": {"scan.ply"},
    "execute": {"scan.ply", "commissioning.json"},
    "export": {
        "scan.ply",
        "commissioning.json",
        "targets.csv",
        "targets.json",
        "tooldata.json",
        "program.mod",
        "execution.json",
    },
}
# Lines of the stages after those stopped here, and of a run's end: none may follow a signal.
LATER = ("match:", "scan check", "verify:", "surface:", "probe:", "pick:", "program",
         "executed", "aborted", "refused", "run folder:")  # fmt: skip


@dataclass(frozen=True)
class Stopped:
    returncode: int
    lines: list[str]  # stderr, every line
    after: list[str]  # stderr after the signal was sent
    seconds_to_exit: float
    folder: Path


def _run_and_stop(case: Case, out: Path) -> Stopped:
    sets = [arg for s in case.settings for arg in ("--set", s)]
    # The run yields the CPU to this test (nice 10): on a loaded machine the test sees its
    # marker and signals it before the run has moved on a stage (nice execs it: same pid).
    command = ["nice", "-n", "10", sys.executable, "-c", RESET_SIGNALS, str(TWINCELL), "run",
               case.job, "--out", str(out), *sets]  # fmt: skip
    process = subprocess.Popen(
        command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, bufsize=1
    )
    lines: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            lines.put(line.rstrip("\n"))
        lines.put(None)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    seen: list[str] = []
    deadline = time.monotonic() + 180
    try:
        while True:
            assert time.monotonic() < deadline, f"no {case.marker!r} in time: {seen}"
            try:
                line = lines.get(timeout=0.005)
            except queue.Empty:
                line = ""
            assert line is not None, f"the run ended before {case.marker!r}: {seen}"
            if line:
                seen.append(line)
            if case.marker_is_file:
                if list(out.glob(f"{case.job}-*/{case.marker}")):
                    break
            elif line.strip().startswith(case.marker):
                break
        time.sleep(case.delay_s)
        t_signal = time.monotonic()
        os.kill(process.pid, signal.Signals[case.signal_name])
        returncode = process.wait(timeout=120)
        seconds = time.monotonic() - t_signal
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        reader.join(timeout=10)
        if process.stderr is not None:
            process.stderr.close()
    after = []
    while (line := lines.get_nowait()) is not None:
        after.append(line)
    return Stopped(returncode, seen + after, after, seconds, _one_folder(out))


def _check_complete(path: Path, scan_points: int | None) -> None:
    """The file is whole: it parses, and scan.ply has every object point the scan kept."""
    if path.suffix == ".json":
        json.loads(path.read_text())
    elif path.name == "scan.ply":
        assert scan_points is not None and len(read_ply(path)) == scan_points
    elif path.suffix == ".yaml":
        assert yaml.safe_load(path.read_text())["name"]
    elif path.suffix == ".csv":
        rows = path.read_text().splitlines()
        # a header, then an approach and a touch row for each of the 4 targets
        assert len(rows) == 9 and len({len(r.split(",")) for r in rows}) == 1
    elif path.suffix == ".mod":
        assert path.read_text().rstrip().endswith("ENDMODULE")
    else:
        raise AssertionError(f"unexpected file {path.name}")


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.slow
def test_a_signal_stops_the_run_in_its_stage_and_leaves_only_whole_files(
    name: str, tmp_path: Path
) -> None:
    case = CASES[name]
    stopped = _run_and_stop(case, tmp_path)
    status = {"SIGTERM": 143, "SIGINT": 130}[case.signal_name]
    assert stopped.returncode == status, stopped.lines
    # One line says it, the last; no traceback, and the run said nothing more of its stages.
    line = (
        f"twincell: interrupted ({case.signal_name}) during {case.stage}; "
        f"run folder {stopped.folder}"
    )
    assert stopped.lines[-1] == line, stopped.lines
    extra = [x for x in stopped.lines if "Traceback" in x or x.startswith("twincell:")][:-1]
    assert not extra, "\n".join(stopped.lines)  # all of stderr, to see where it came from
    assert not [x for x in stopped.after[:-1] if x.strip().startswith(LATER)], stopped.after
    assert stopped.seconds_to_exit < 30  # it wound down rather than ran on

    results = json.loads((stopped.folder / "results.json").read_text())
    assert results["status"] == "incomplete"
    assert results["reason"] == f"interrupted ({case.signal_name})"
    assert results["stage"] == case.stage
    assert (results["job"], results["seed"]) == (case.job, 0)

    names = {p.name for p in stopped.folder.iterdir()}
    assert "run.rrd" not in names
    assert not [n for n in names if n.startswith(".")], names  # no temporary file
    assert names - {"config.yaml", "results.json"} <= WRITTEN_BEFORE[case.stage], names
    counts = [re.match(r"scan: \d+ points, (\d+) on the object", x.strip()) for x in stopped.lines]
    scan_points = next((int(m.group(1)) for m in reversed(counts) if m), None)  # the last scan
    for n in names:
        _check_complete(stopped.folder / n, scan_points)
    assert (tmp_path / "latest").resolve() == stopped.folder.resolve()
