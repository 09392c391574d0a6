"""Targets (burr holes) of a user's mesh: read from a targets file beside it, or generated on
its upper surface.

A targets file is `<mesh stem>.targets.yaml` beside the mesh, in the mesh's units:

    - {name: a, entry: [x, y, z], direction: [dx, dy, dz], depth: 40}
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from models.model import ObjectModel
from models.targets import BurrHole
from models.units import unit_scale
from scenarios.scenario_errors import ScenarioError

#: The table's vertical in the frame of a model lying as modelled: its z axis.
UP = np.array([0.0, 0.0, 1.0])


class TargetsFileError(ScenarioError, ValueError):
    """A targets file is missing keys or has bad values."""


def targets_path(mesh_path: str | Path) -> Path:
    """Where the targets of `mesh_path` are looked for: `<stem>.targets.yaml` beside it."""
    p = Path(mesh_path)
    return p.with_name(f"{p.stem}.targets.yaml")


def read_targets(path: str | Path, units: str) -> tuple[BurrHole, ...]:
    """Burr holes from a targets file (lengths in `units`, converted to metres)."""
    scale = unit_scale(units)
    try:
        items = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise TargetsFileError(f"{path}: cannot read the targets: {exc}") from None
    if not isinstance(items, list) or not items:
        raise TargetsFileError(f"{path}: expected a non-empty list of targets")
    holes = []
    for i, item in enumerate(items):
        keys = {"name", "entry", "direction", "depth"}
        if not isinstance(item, dict) or set(item) != keys:
            got = sorted(item) if isinstance(item, dict) else item
            raise TargetsFileError(f"{path}: target {i} must have keys {sorted(keys)}, got {got}")
        try:
            holes.append(
                BurrHole(
                    str(item["name"]),
                    np.asarray(item["entry"], dtype=float) * scale,
                    np.asarray(item["direction"], dtype=float),
                    float(item["depth"]) * scale,
                )
            )
        except (ValueError, TypeError) as exc:
            raise TargetsFileError(f"{path}: target {i}: {exc}") from None
    return tuple(holes)


def generate_targets(
    model: ObjectModel, count: int = 4, seed: int = 0, up_model: np.ndarray = UP
) -> tuple[BurrHole, ...]:
    """`count` targets spread over the model's upper surface (vertices whose normal points
    up, in the top third of its height), the trajectory along the inward normal, depth a
    fifth of the model's height; up is `up_model` (3,), the table's vertical in the model
    frame as it lies (its z unless turned: a placement's up axis, roll and pitch)."""
    mesh = model.mesh
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    n_face = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normals = np.zeros_like(v)
    for k in range(3):
        np.add.at(normals, f[:, k], n_face)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    height = v @ up_model
    lo, hi = height.min(), height.max()
    ok = np.flatnonzero((normals @ up_model > 0.8) & (height > lo + 2 * (hi - lo) / 3))
    if len(ok) < count:
        raise TargetsFileError(
            f"model {model.name!r} has too little upward-facing upper surface to place "
            f"{count} targets; give a targets file"
        )
    rng = np.random.default_rng(seed)
    chosen = [int(rng.choice(ok))]
    d = np.linalg.norm(v[ok] - v[chosen[0]], axis=1)
    while len(chosen) < count:  # farthest-point spread
        k = int(ok[np.argmax(d)])
        chosen.append(k)
        d = np.minimum(d, np.linalg.norm(v[ok] - v[k], axis=1))
    depth = (hi - lo) / 5
    return tuple(
        BurrHole(f"target_{i + 1}", v[k], -normals[k], depth) for i, k in enumerate(chosen)
    )
