"""A run.rrd read back with rerun's own reader (rerun.chunk.RrdReader), for the tests: each
entity's static components and its timed rows, and the latest-at answer at a time."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rerun.chunk as rc


@dataclass
class Entity:
    """Static components by name; timed rows as (sim_time [s] or None, icp step or None,
    components by name)."""

    static: dict[str, Any] = field(default_factory=dict)
    rows: list[tuple[float | None, int | None, dict[str, Any]]] = field(default_factory=list)

    def timed(self, component: str, timeline: str = "sim_time") -> list[tuple[float, Any]]:
        """(time, value) of the rows on `timeline` that carry `component`, by time."""
        out = [
            (t if timeline == "sim_time" else i, c[component])
            for t, i, c in self.rows
            if component in c and (t if timeline == "sim_time" else i) is not None
        ]
        return sorted(out, key=lambda r: r[0])

    def latest(self, component: str, time_s: float) -> Any:
        """The value of `component` at `time_s` on sim_time (latest at), else static."""
        before = [v for t, v in self.timed(component) if t <= time_s]
        if before:
            return before[-1]
        return self.static.get(component)

    def first_time(self) -> float | None:
        times = [t for t, _, _ in self.rows if t is not None]
        return min(times) if times else None


def read_rrd(path: Path, wanted: tuple[str, ...] | None = None) -> dict[str, Entity]:
    """Entities of the recording at `path` (only those starting with one of `wanted`)."""
    out: dict[str, Entity] = defaultdict(Entity)
    for chunk in rc.RrdReader(path).stream().to_chunks():
        path_ = chunk.entity_path
        if wanted is not None and not path_.startswith(wanted):
            continue
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if ":" in n]
        entity = out[path_]
        if chunk.is_static:
            for n in names:
                entity.static[n] = batch.column(n)[batch.num_rows - 1].as_py()
            continue
        times = (
            batch.column("sim_time").cast("int64").to_numpy() * 1e-9
            if "sim_time" in batch.schema.names
            else None
        )
        steps = (
            batch.column("icp").cast("int64").to_numpy() if "icp" in batch.schema.names else None
        )
        columns = {n: batch.column(n).to_pylist() for n in names}
        for k in range(batch.num_rows):
            comps = {n: columns[n][k] for n in names if columns[n][k] is not None}
            entity.rows.append(
                (
                    None if times is None else float(times[k]),
                    None if steps is None else int(steps[k]),
                    comps,
                )
            )
    return dict(out)


def pose(translation: Any, quaternion: Any) -> np.ndarray:
    """(4, 4) of a rerun Transform3D's translation and xyzw quaternion."""
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(np.asarray(quaternion, dtype=float)).as_matrix()
    T[:3, 3] = np.asarray(translation, dtype=float)
    return T
