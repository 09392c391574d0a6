"""A disk cache of scan plans, beside the model cache (models.cache: the same folder, the
same switch).

A scan plan is a function of the virtual cell alone: the arm, the object's virtual model
and its nominal pose, the targets, and the planning settings. Choosing one takes seconds
(each candidate pass's lines solved and cleared, the laser's view of the model cast, the
targets' errors predicted); a job run again on the same model reads it back instead.

A plan is stored under a hash of all of those inputs and of the planning code's own source
(the packages cell, models, registration, scenarios.offline and scenarios.stages), so a
changed planner or model never reads a plan an older one wrote. The file is the plan
pickled (a tree of frozen dataclasses and arrays), written atomically into the user's own
cache folder; a file that does not read back is planned anew and replaced.
"""

from __future__ import annotations

import contextlib
import hashlib
import pickle
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

import numpy as np

from cell.robots import Robot
from models import cache
from models.atomic import write_atomic
from models.model import ObjectModel
from scenarios.offline.scan_plan import ScanPlan
from scenarios.offline.settings import PlanningSettings

#: The layout of the cache's files; a file of another layout is planned anew.
FORMAT = 1
#: The packages whose source a plan depends on (relative to the project's root).
PLANNING_CODE = ("cell", "models", "registration", "scenarios/offline", "scenarios/stages")


@lru_cache(maxsize=1)
def code_hash() -> str:
    """A hash of the planning code's source (PLANNING_CODE)."""
    root = Path(__file__).resolve().parents[2]
    digest = hashlib.sha256()
    for package in PLANNING_CODE:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def plan_key(
    robot: Robot,
    settings: PlanningSettings,
    virtual: ObjectModel,
    T_table_object: np.ndarray,
    targets_model: np.ndarray,
    target_names: tuple[str, ...] | None,
) -> str:
    """The cache key of the scan plan of these inputs (what job_scan_plan is given)."""
    digest = hashlib.sha256()
    kin = robot.kinematics()
    parts: list[bytes] = [
        f"format {FORMAT} code {code_hash()} robot {robot.name} {robot.tip_frame}".encode(),
        robot.mjcf().encode(),
        settings.model_dump_json().encode(),
        repr(target_names).encode(),
    ]
    arrays = [robot.q_home, robot.joint_speed, robot.T_world_base, kin.lower, kin.upper]
    for tool in sorted(kin.tool_limits, key=str):
        arrays.extend(kin.tool_limits[tool])
    arrays += [virtual.mesh.vertices, virtual.mesh.faces, T_table_object, targets_model]
    for part in parts:
        digest.update(len(part).to_bytes(8, "little") + part)
    for array in arrays:
        a = np.ascontiguousarray(array)
        digest.update(f"{a.dtype.str}{a.shape}".encode() + a.tobytes())
    return f"{virtual.name}-seed{settings.seed}-{digest.hexdigest()[:20]}"


def folder() -> Path:
    """Where the cache keeps its plans: `plans` in the model cache's folder."""
    return cache.folder() / "plans"


def cached_plan(key: str, plan: Callable[[], ScanPlan]) -> tuple[ScanPlan, bool]:
    """The scan plan stored under `key`, or planned by `plan()` and stored; and whether it
    came from the cache. With the cache off (TWINCELL_NO_CACHE), always planned."""
    if not cache.enabled():
        return plan(), False
    path = folder() / f"{key}.pickle"
    stored = _read(path)
    if stored is not None:
        return stored, True
    made = plan()
    with contextlib.suppress(OSError):  # a read-only cache folder costs time, not results
        write_atomic(path, lambda tmp: tmp.write_bytes(pickle.dumps(made, protocol=5)))
    return made, False


def _read(path: Path) -> ScanPlan | None:
    """The plan stored at `path`, or None: no file, or one that is damaged or not a plan
    (planned anew and replaced)."""
    try:
        stored = pickle.loads(path.read_bytes())
    except Exception:  # any failure to read it back means: plan anew
        return None
    return stored if isinstance(stored, ScanPlan) else None
