"""A network job's touches as the twin measures them (scenarios.jobs.network_job.TwinTouches):
each touch is a stop named for its target, and each measurement the twin writes is paired
with the touch it was, in order, so that two localization methods touching the same targets
each get their own measurements (the assembly job's surface and probe)."""

from __future__ import annotations

import json
from types import SimpleNamespace
from typing import Any

import numpy as np

from scenarios.irc5.move_modules import MODULE
from scenarios.jobs.network_job import TwinTouches, touch_robtarget


def _measured(name: str, error_m: float) -> dict[str, object]:
    return {
        "name": name, "error_m": error_m, "axis_error_deg": 0.0, "depth_error_m": 0.0,
        "p_true_base_m": [1.0, 0.0, 0.5], "p_achieved_base_m": [1.0, 0.0, 0.5 + error_m],
    }  # fmt: skip


class Twin:
    """A controller whose stops named for a target the twin measures: each stop writes one
    execution file with that target's measurement (its error the next of `errors`)."""

    def __init__(self, errors: list[float]) -> None:
        self.errors = errors
        self.written: dict[str, bytes] = {"000-Before.json": b"{}"}  # an earlier job's
        self.stops: list[str] = []
        self.link = SimpleNamespace(files=self.files, read_file=self.read_file)

    def files(self, _folder: str) -> list[str]:
        return sorted(self.written)

    def read_file(self, path: str) -> bytes:
        return self.written[path.rpartition("/")[2]]

    def stop_named(self, robtarget: str) -> None:
        self.stops.append(robtarget)
        name = {touch_robtarget(n): n for n in ("left", "right")}[robtarget]
        record = {"program": f"{MODULE}.mod", "targets": [_measured(name, self.errors.pop(0))]}
        self.written[f"{len(self.written):03d}-{MODULE}.json"] = json.dumps(record).encode()


def test_two_methods_touching_the_same_targets_each_get_their_own_measurements() -> None:
    twin = Twin([1e-4, 2e-4, 3e-4, 4e-4, 5e-4])
    touches = TwinTouches(twin, ("left", "right"))  # type: ignore[arg-type]
    for name in ("surface:left", "surface:right", "probe:left", "probe:right", "probe:left"):
        touches.record_touch(name, "screwer")
    touches.record_touch("pick: closed", "gripper")  # a moment, not a target: no stop
    assert twin.stops == [touch_robtarget(n) for n in ("left", "right", "left", "right", "left")]
    holes = [
        SimpleNamespace(name=n, p_entry=np.array([1.0, 0.0, 0.5]), direction=np.array([0, 0, 1]))
        for n in ("left", "right")
    ]
    virtual: Any = SimpleNamespace(burr_holes=holes)

    def errors(prefix: str) -> dict[str, float]:
        found = touches.targets(0.0, virtual, np.eye(4), prefix)
        return {t.name: t.error_m for t in found}

    assert errors("surface:") == {"surface:left": 1e-4, "surface:right": 2e-4}
    # the last touch of a target is its measurement (probe:left touched twice)
    assert errors("probe:") == {"probe:left": 5e-4, "probe:right": 4e-4}
