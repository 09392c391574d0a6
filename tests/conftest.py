"""Shared fixtures: the real range scans of tests/data/stanford (see its README) and the
short skull job that several files inspect, run once per session."""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from registration import MeshModel, load_points
from registration.io.mesh_files import read_mesh

STANFORD = Path(__file__).parent / "data" / "stanford"


#: The slow tier's longest modules, longest first (seconds of one worker, measured): they are
#: handed out first, so that the two workers finish together instead of one running a long
#: module alone at the end (pytest-xdist's --dist loadfile with --no-loadscope-reorder).
LONGEST_FIRST = (
    "test_readme_tables.py",  # 230
    "test_controller_client.py",  # 110: a job across the network
    "test_docs_commands.py",  # 160
    "test_bench.py",  # 165
    "test_faults.py",  # 160
    "test_scan_plan.py",  # 120
    "test_verify_curve.py",  # 75
    "test_shift.py",  # 65: a shift of three jobs
    "test_interrupt.py",  # 70
    "test_calibration_benefit.py",  # 70
    "test_campaign_shift.py",  # 50: two shifts of two jobs
)


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int | None:
    """`-n auto` (pyproject.toml's addopts): a worker per CPU this process may keep busy
    (scenarios.workers.usable_cpus), instead of pytest-xdist's count of the machine's
    physical cores (psutil), which is one on two hardware threads of one core and the host's
    on a container given fewer. PYTEST_XDIST_AUTO_NUM_WORKERS still decides where set."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None  # pytest-xdist's own hook reads it
    from scenarios.workers import usable_cpus

    return usable_cpus()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable for the rest


@dataclass(frozen=True)
class RealScan:
    """One real range view: its points (N, 3) in the scanner's frame [m] and the
    ground-truth pose T_model_scan (4, 4) from the scanning repository's alignment."""

    object: str
    name: str
    points: np.ndarray
    T_model_scan: np.ndarray


@dataclass(frozen=True)
class RealObject:
    """A reconstructed model (vertices, faces) [m] and its real views."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    scans: tuple[RealScan, ...]

    def model(self) -> MeshModel:
        return MeshModel(self.vertices, self.faces)


def load_real(name: str) -> RealObject:
    folder = STANFORD / name
    poses = json.loads((folder / "poses.json").read_text())["scans"]
    vertices, faces = read_mesh(folder / "model.ply", points_only=False)
    assert faces is not None
    scans = tuple(
        RealScan(name, file, load_points(folder / file), np.array(entry["T_model_scan"]))
        for file, entry in poses.items()
    )
    return RealObject(name, vertices, faces, scans)


@pytest.fixture(scope="session")
def real_objects() -> tuple[RealObject, ...]:
    """The dragon and the Happy Buddha: 9 real views with their true poses."""
    return (load_real("dragon"), load_real("happy"))


# -- one job that several files inspect, run once per session ------------------------------------
#: The short skull job of tests/test_scenarios_run.py (its folder, results and exports),
#: tests/test_recording.py (its recording), tests/test_scan_plan.py (its chosen passes) and
#: tests/test_execute.py (a run folder): seed 11, the passes chosen in the virtual cell for
#: the targets, 20 ms lines.
SHORT_SKULL = """seed: 11
localization:
  scan: {speed_m_s: 0.25, period_s: 0.02, plan: auto}
"""


@contextmanager
def _exclusive(lock: Path) -> Iterator[None]:
    """Hold an exclusive lock on the file `lock` (created if missing) while in the block."""
    with open(lock, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


#: The packages whose files a run depends on, and the libraries whose versions it does.
_PACKAGES = ("cell", "models", "registration", "scenarios")
_LIBRARIES = ("mujoco", "pin", "numpy", "scipy", "trimesh", "rerun-sdk", "libigl")


def _code_key(job: str) -> str:
    """A digest of the job's text, every file of the packages and the libraries' versions:
    a run kept under it was made by this code, on these libraries."""
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256(job.encode())
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(root)).encode())
                digest.update(path.read_bytes())
    for library in _LIBRARIES:
        digest.update(f"{library}={metadata.version(library)}".encode())
    digest.update(sys.version.encode())
    return digest.hexdigest()[:20]


@pytest.fixture(scope="session")
def short_skull_run(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The run folder of `twincell run short.yaml` (SHORT_SKULL, with its recording and
    figures), run once: under pytest-xdist the first worker to need it runs it while any
    other waits, then all read it. It is kept in pytest's cache under a digest of the code
    and the libraries (`_code_key`), so that the next session on the same code (the slow
    tier after the fast one) reads it instead of running it again; without the cache
    (`-p no:cacheprovider`), in the session's temporary folder. The tests read the folder
    and write nothing into it."""
    from scenarios.cli.app import main

    cache = getattr(pytestconfig, "cache", None)
    if cache is not None:
        home = Path(cache.mkdir("twincell_short_skull"))
    else:
        base = tmp_path_factory.getbasetemp()
        if "PYTEST_XDIST_WORKER" in os.environ:
            base = base.parent  # each worker's is one folder of the session's
        home = base / "short_skull"
        home.mkdir(exist_ok=True)
    root = home / _code_key(SHORT_SKULL)
    with _exclusive(home / "lock"):
        if not (root / "complete").is_file():
            for old in home.iterdir():  # what a failed attempt or older code left
                if old.is_dir():
                    shutil.rmtree(old, ignore_errors=True)
            root.mkdir()
            config = root / "short.yaml"
            config.write_text(SHORT_SKULL)
            assert main(["run", str(config), "--out", str(root / "out"), "--quiet"]) == 0
            (root / "complete").touch()
    return (root / "out" / "latest").resolve()
