"""A plan made on a volume: entry and target points in the volume's patient frame [mm].

    {"frame": "RAS", "targets": [{"name": "kocher_right", "entry": [x, y, z],
                                  "target": [x, y, z]}, ...]}

`frame` must be the volume's own (LPS for DICOM, RAS for NIfTI; an NRRD says which); the
points must lie within the volume. They become burr holes in the model frame of the volume's
meshes (volume.py), so the job corrects them with the same pose as the model.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from models.ct.volume import Volume, VolumeError, lps_mm_to_model
from models.targets import BurrHole


def read_plan(path: str | Path, volume: Volume) -> tuple[BurrHole, ...]:
    """The plan at `path` on `volume` as burr holes (model frame, m)."""
    path = Path(path)
    try:
        plan = json.loads(path.read_text())
        frame = plan["frame"]
        items = plan["targets"]
        names = [str(t["name"]) for t in items]
        entry = np.array([t["entry"] for t in items], dtype=float).reshape(-1, 3)
        target = np.array([t["target"] for t in items], dtype=float).reshape(-1, 3)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise VolumeError(
            f"{path}: not a plan ({exc}); expected {{'frame': 'LPS'|'RAS', 'targets': "
            "[{'name', 'entry': [x, y, z], 'target': [x, y, z]}]}} in mm"
        ) from None
    if not names:
        raise VolumeError(f"{path}: the plan has no targets")
    if frame != volume.native_frame:
        raise VolumeError(
            f"{path}: the plan is in {frame!r}, the volume {volume.source} in "
            f"{volume.native_frame!r}: a plan is made in its volume's frame"
        )
    holes = []
    for name, e, t in zip(names, entry, target, strict=True):
        e_lps, t_lps = volume.native_to_lps(np.array([e, t]), frame)
        outside = ~volume.contains(np.array([e_lps, t_lps]))
        if outside.any():
            which = "entry" if outside[0] else "target"
            raise VolumeError(f"{path}: {name}'s {which} {[e, t][int(not outside[0])].tolist()} "
                              f"mm lies outside the volume {volume.source}")  # fmt: skip
        if np.linalg.norm(t_lps - e_lps) < 1e-3:
            raise VolumeError(f"{path}: {name}'s entry and target are the same point")
        p_entry, p_target = lps_mm_to_model(e_lps), lps_mm_to_model(t_lps)
        depth = float(np.linalg.norm(p_target - p_entry))
        holes.append(BurrHole(name, p_entry, (p_target - p_entry) / depth, depth))
    return tuple(holes)
