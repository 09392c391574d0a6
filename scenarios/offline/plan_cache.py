"""A disk cache of scan plans, beside the model cache (models.cache: the same folder, the
same switch).

A scan plan is a function of the virtual cell alone: the arm, the object's virtual model
and its nominal pose, the targets, and the planning settings. Choosing one takes seconds
(each candidate pass's lines solved and cleared, the laser's view of the model cast, the
targets' errors predicted); a job run again on the same model reads it back instead.

A plan is stored under a hash of all of those inputs and of the planning code's own source
(the packages cell, models, registration, scenarios.offline and scenarios.stages), so a
changed planner or model never reads a plan an older one wrote. The file is a numpy .npz
read without pickle (opening one runs no code from it): the plan's tree of frozen
dataclasses as JSON, naming only the plan's own types (PLAN_TYPES), with its arrays beside
it, to the bit. It is written atomically into the user's own cache folder; a file that does
not read back as a plan is reported (a warning on this module's logger) and planned anew
and replaced.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import fields, is_dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel

from cell.robot_arm import Robot
from models import cache
from models.atomic import write_atomic
from models.model import ObjectModel
from scenarios.offline.scan_candidates import Candidate
from scenarios.offline.scan_choice import ChosenPass
from scenarios.offline.scan_passes import PlannedPass
from scenarios.offline.scan_plan import ScanPlan
from scenarios.offline.settings import PlanningSettings, ScanPass

log = logging.getLogger(__name__)

#: The layout of the cache's files; a file of another layout is planned anew. (1: pickled
#: plans, `.pickle`, no longer read.)
FORMAT = 2
#: The types a plan file may name: the plan's tree of values, nothing else.
PLAN_TYPES: dict[str, type] = {
    t.__name__: t for t in (ScanPlan, PlannedPass, ChosenPass, Candidate, ScanPass)
}
#: What reading a damaged, cut or foreign plan file raises (np.load, zipfile, zlib, json,
#: the plan's constructors; pydantic's ValidationError is a ValueError).
BAD_FILE_ERRORS = (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile, zlib.error)
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


def cached_plan(
    key: str, plan: Callable[[], ScanPlan], use_cache: bool = True
) -> tuple[ScanPlan, bool]:
    """The scan plan stored under `key`, or planned by `plan()` and stored; and whether it
    came from the cache. With the cache off (`use_cache` False, or TWINCELL_NO_CACHE: see
    models.cache.enabled), always planned. A file that does not read back as a plan is
    reported on this module's logger and replaced."""
    if not cache.enabled(use_cache):
        return plan(), False
    path = folder() / f"{key}.npz"
    if path.is_file():
        try:
            return read_plan(path), True
        except PlanFileError as exc:
            log.warning("scan plan cache: %s; planning anew and replacing it", exc)
    made = plan()
    encoded = encode_plan(made)
    with contextlib.suppress(OSError):  # a read-only cache folder costs time, not results
        write_atomic(path, lambda tmp: tmp.write_bytes(encoded))
    return made, False


class PlanFileError(ValueError):
    """A plan file that does not read back as a plan: damaged, cut, of another layout."""


def encode_plan(plan: ScanPlan) -> bytes:
    """The .npz bytes of a plan: its tree as JSON (`tree`), its arrays as `a0`, `a1`, ..."""
    arrays: dict[str, Any] = {}
    tree = _encode(plan, arrays)
    arrays |= {"format": np.array(FORMAT), "tree": np.array(json.dumps(tree))}
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def read_plan(path: Path) -> ScanPlan:
    """The plan in the file at `path` (written by encode_plan); PlanFileError, naming the
    file, if it is not one, saying why."""
    try:
        # The file opened here, closed here: np.load leaves its own open on a cut archive.
        with path.open("rb") as f, np.load(f, allow_pickle=False) as data:
            found = int(data["format"]) if "format" in data.files else "none"
            if found != FORMAT:
                raise PlanFileError(f"layout {found}, this code reads {FORMAT}")
            arrays = {name: data[name] for name in data.files if name not in ("format", "tree")}
            plan = _decode(json.loads(str(data["tree"])), arrays)
    except PlanFileError as exc:
        raise PlanFileError(f"{path}: {exc}") from None
    except BAD_FILE_ERRORS as exc:
        raise PlanFileError(f"{path}: not a readable plan ({type(exc).__name__}: {exc})") from None
    if not isinstance(plan, ScanPlan):
        raise PlanFileError(f"{path}: holds a {type(plan).__name__}, not a ScanPlan")
    return plan


def _encode(value: Any, arrays: dict[str, Any]) -> Any:
    """The JSON form of a value of a plan's tree; its arrays go into `arrays`."""
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise TypeError(f"a plan's arrays hold numbers; got one of {value.dtype}")
        name = f"a{len(arrays)}"
        arrays[name] = value
        return {"array": name}
    if isinstance(value, tuple):
        return {"tuple": [_encode(v, arrays) for v in value]}
    kind = type(value).__name__
    if PLAN_TYPES.get(kind) is not type(value):
        raise TypeError(f"a plan file stores {', '.join(PLAN_TYPES)}; got a {kind}")
    if isinstance(value, BaseModel):
        names = list(type(value).model_fields)
    elif is_dataclass(value):
        names = [f.name for f in fields(value) if f.init]
    else:  # pragma: no cover - PLAN_TYPES holds dataclasses and pydantic models only
        raise TypeError(f"cannot store a {kind}")
    return {"type": kind, "fields": {n: _encode(getattr(value, n), arrays) for n in names}}


def _decode(node: Any, arrays: dict[str, np.ndarray]) -> Any:
    """The value of a JSON node written by _encode, with its arrays from `arrays`."""
    if not isinstance(node, dict):
        return node
    if "array" in node:
        return arrays[node["array"]]
    if "tuple" in node:
        return tuple(_decode(v, arrays) for v in node["tuple"])
    kind = PLAN_TYPES[node["type"]]
    values = {name: _decode(v, arrays) for name, v in node["fields"].items()}
    try:
        return kind(**values)
    except TypeError as exc:  # fields that the type does not have: another layout
        raise PlanFileError(f"a {kind.__name__} with other fields ({exc})") from None
