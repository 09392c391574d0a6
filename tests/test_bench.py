"""Every benchmark runs: each script in bench/ in its short mode (`--short`), in a fresh
process as a user runs it, exits 0 and prints its table's header (readme_tables.py's is
tests/test_readme_tables.py's assembly row). The benchmarks the README and the documentation
name are all among them, and a script added to bench/ without a short run here fails."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"

#: Each script, whether its short mode takes an output folder (--out), and its tables'
#: headers: each the words that one line of its output must hold.
SHORT_RUNS: dict[str, tuple[bool, tuple[tuple[str, ...], ...]] | None] = {
    "budget_coverage.py": (False, (("set", "runs", "targets within their bound", "at risk"),)),
    "bench_campaign.py": (
        False,
        (
            ("backend", "workers", "trials", "wall [s]", "trials/s", "same rows"),
            ("stage", "version", "repeat", "trials", "seconds", "trials/min"),
        ),
    ),
    "bench_cell.py": (False, (("measure", "ours", "peer", "ours / peer"),)),
    "bench_ct.py": (True, (("seconds", "peak GB", "faces", "watertight"),)),
    "bench_recording.py": (
        True,
        (("seed", "with run.rrd", "without", "ratio", "run.rrd [MB]", "chunks"),),
    ),
    "bench_rapid_corpus.py": (
        False,
        (("source", "files", "read before", "refused before", "read after", "refused after"),),
    ),
    "bench_register_cli.py": (False, (("input", "form", "wall s", "match s"),)),
    "bench_registration.py": (
        False,
        (
            ("method", "right", "accepted", "false acc.", "median s"),
            ("method", "median ms", "right", "rms mm"),
            ("method", "queries/s"),
        ),
    ),
    "bench_scan_plan.py": (
        False,
        (("job", "plan", "passes", "cell time [s]", "worst TRE [mm]", "planner [s]"),),
    ),
    "bench_skull.py": (
        True,
        (
            ("version", "cache", "whole command"),
            ("stage", "rerun on", "rerun off"),
            ("points used", "seconds", "verdict", "pose error [deg, mm]"),
            ("seed", "status", "ambiguity", "RMS", "max", "goal"),
        ),
    ),
    # Its short run is tests/test_readme_tables.py's assembly row (docs/benchmarks.md).
    "readme_tables.py": None,
    # a job across the network: tests/test_controller_client.py runs one against the twin
    "bench_network_job.py": None,
    # the latency found through a twin served per latency: tests/test_controller_client.py
    # finds 0, 8 (in the job) and 20 ms
    "bench_laser_latency.py": None,
    # the point laser's cell: tests/test_point_laser.py runs its skull job (seed 0)
    "bench_point_laser.py": None,
    "same_figures.py": (False, (("run", "keys compared", "keys that differ"),)),
    "verify_curve.py": (
        False,
        tuple(
            (f"| {fault} [mm]", "trials", "detected", "beyond the goal")
            for fault in ("object_bump", "table_stall", "tool_lock_fail")
        ),
    ),
    "viewer_check.py": (True, (("moment", "view", "colour", "pixels"),)),
}


def _holds(output: str, words: tuple[str, ...]) -> bool:
    return any(all(w in line for w in words) for line in output.splitlines())


def test_every_script_has_a_short_run() -> None:
    scripts = {p.name for p in BENCH.glob("*.py")}
    assert scripts == set(SHORT_RUNS), "give each script in bench/ a --short run here"


def test_the_readme_and_docs_name_only_these_scripts() -> None:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    named = {n for page in pages for n in re.findall(r"bench/(\w+\.py)", page.read_text())}
    assert named, "the README and the docs name no benchmark"
    assert named <= set(SHORT_RUNS), named - set(SHORT_RUNS)


@pytest.mark.parametrize("script", sorted(k for k, v in SHORT_RUNS.items() if v is not None))
def test_short_run(script: str, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    run = SHORT_RUNS[script]
    assert run is not None
    takes_out, headers = run
    command = [sys.executable, str(BENCH / script), "--short"]
    command += ["--out", str(tmp_path / "out")] if takes_out else []
    if script == "viewer_check.py":
        if shutil.which("Xvfb") is None:
            pytest.skip("no Xvfb: the rerun viewer needs a virtual display server here")
        # The recording of the session's short skull run (tests/conftest.py), not a run of
        # its own: a fresh `twincell run` recording all the same.
        command.append(str(request.getfixturevalue("short_skull_run")))
    # Wide enough that rich's tables keep each header on one line; the scripts' temporary
    # folders in the test's own.
    env = {**os.environ, "COLUMNS": "240", "TMPDIR": str(tmp_path)}
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=1800
    )
    assert done.returncode == 0, f"{script} --short exited {done.returncode}:\n{done.stderr}"
    for words in headers:
        assert _holds(done.stdout, words), f"{script}: no line holds {words}:\n{done.stdout}"
