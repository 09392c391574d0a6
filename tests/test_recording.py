"""The run's recording read back with rerun's own reader: the bodies where the laser saw
them, every result at the time it was computed and not before, the ICP on its own timeline.

Ground truth here is the recording's own geometry as the physics placed it (the rays are
the real laser's rays, witnessed in the simulation) and the run's results.json: the tests
check that what a user sees agrees with itself and with the run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rrd_reader import Entity, pose, read_rrd

from registration import MeshModel

#: A ray ends where the laser measured: 5 sigma of its range noise (20 um) plus a 3 sigma
#: range scale error (3e-4) at its longest range (0.6 m) [m].
RAY_TOL_M = 5 * 20e-6 + 3 * 3e-4 * 0.6


@pytest.fixture(scope="module")
def run(short_skull_run: Path) -> tuple[Path, dict[str, Entity]]:
    """The short skull job (tests/conftest.py's SHORT_SKULL, run once a session) and its
    recording as rerun reads it."""
    return short_skull_run, read_rrd(short_skull_run / "run.rrd")


def _phase(entities: dict[str, Entity], name: str) -> float:
    for t, _, c in entities["/log"].rows:
        if t is not None and c["TextLog:text"][0].startswith(f"== {name} =="):
            return t
    raise AssertionError(f"no phase {name!r} in the log")


def _world(entity: Entity, time_s: float) -> np.ndarray:
    return pose(
        entity.latest("Transform3D:translation", time_s)[0],
        entity.latest("Transform3D:quaternion", time_s)[0],
    )


def _box_distance(q: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Distance (N,) of points (N, 3) in a box's frame from its surface."""
    outside = np.linalg.norm(np.maximum(np.abs(q) - half, 0.0), axis=1)
    inside = np.min(half - np.abs(q), axis=1)
    return np.where(outside > 0.0, outside, np.abs(inside))


def test_rays_end_on_the_logged_table_or_object(run: tuple[Path, dict[str, Entity]]) -> None:
    """During the scan every drawn ray ends on a logged surface, with that surface's pose
    at the ray's time: the table's top, the object, or a sphere fixed on the table."""
    _, e = run
    scan, register = _phase(e, "scan"), _phase(e, "register")
    rays = [(t, s) for t, s in e["/world/laser/rays"].timed("LineStrips3D:strips") if s]
    during = [(t, s) for t, s in rays if scan < t < register]
    assert len(during) > 100
    skull = e["/world/cell/skull"]
    mesh = MeshModel(
        np.asarray(skull.static["Mesh3D:vertex_positions"], dtype=float),
        np.asarray(skull.static["Mesh3D:triangle_indices"]),
    )
    boxes = {p: v for p, v in e.items() if "Boxes3D:half_sizes" in v.static and v.rows}
    balls = {p: v for p, v in e.items() if "Ellipsoids3D:half_sizes" in v.static and v.rows}
    assert "/world/cell/table_top" in boxes and len(balls) == 3
    hits = {"/world/cell/table_top": 0, "/world/cell/skull": 0}
    for t, strips in during[:: max(1, len(during) // 40)]:
        ends = np.array([s[1] for s in strips])
        distances = {}
        for path, box in boxes.items():
            T = _world(box, t)
            half = np.asarray(box.static["Boxes3D:half_sizes"][0])
            distances[path] = _box_distance((ends - T[:3, 3]) @ T[:3, :3], half)
        for path, ball in balls.items():
            T = _world(ball, t)
            radius = ball.static["Ellipsoids3D:half_sizes"][0][0]
            distances[path] = np.abs(np.linalg.norm(ends - T[:3, 3], axis=1) - radius)
        T = _world(skull, t)
        local = (ends - T[:3, 3]) @ T[:3, :3]
        distances["/world/cell/skull"] = mesh.closest(local).distances
        nearest = np.min(np.array(list(distances.values())), axis=0)
        assert nearest.max() < RAY_TOL_M, (t, nearest.max())
        for path in hits:
            hits[path] += int((distances[path] < RAY_TOL_M).sum())
    assert min(hits.values()) > 5, hits  # the scan saw both the table and the object


def test_no_result_before_its_stage(run: tuple[Path, dict[str, Entity]]) -> None:
    _, e = run
    scan, register, execute = _phase(e, "scan"), _phase(e, "register"), _phase(e, "execute")
    assert scan < register <= execute
    stages = {
        "/world/cell/table/frame/scan/passes": scan,
        "/world/cell/table/frame/scan/line": scan,
        "/world/cell/table/frame/scan/registered": register,
        "/legend/residual": _phase(e, "calibrate"),
        "/world/cell/table/frame/calibration": _phase(e, "calibrate"),
        "/plots/calibration": _phase(e, "calibrate"),
        "/plots/icp/rms_per_iteration_mm": register,
        "/world/targets": execute,
        "/plots/targets": execute,
    }
    for prefix, start in stages.items():
        found = [p for p in e if p.startswith(prefix)]
        assert found, prefix
        for path in found:
            data = [k for k in e[path].static if not k.endswith(("radii", "colors", "fill_mode"))]
            assert not data, f"{path} has static {data}: shown before it exists"
            first = e[path].first_time()
            assert first is not None and first >= start, (path, first, start)
            # Rows on sim_time carry no stale step of the icp timeline.
            assert all(i is None for t, i, _ in e[path].rows if t is not None), path
    # The calibration's fit appears when the calibration ends, before the scan begins.
    assert e["/world/cell/table/frame/calibration/points"].first_time() <= scan
    # The model stands at its nominal pose until the match, then at the registered one.
    model = e["/world/cell/table/frame/model"].timed("Transform3D:translation")
    assert [t for t, _ in model] == [0.0, pytest.approx(register, abs=1e-6)]


def test_icp_on_its_own_timeline_ends_at_the_registered_pose(
    run: tuple[Path, dict[str, Entity]],
) -> None:
    folder, e = run
    results = json.loads((folder / "results.json").read_text())
    model = e["/world/cell/table/frame/model"]
    steps = model.timed("Transform3D:translation", "icp")
    assert steps[0][0] == 0 and len(steps) >= 4
    final_sim = model.timed("Transform3D:translation")[-1][1][0]
    np.testing.assert_allclose(steps[-1][1][0], final_sim, atol=1e-9)
    starts = e["/world/cell/table/frame/icp/starts"].timed("Points3D:positions", "icp")
    assert starts[0][0] == 0 and len(starts[0][1]) == results["registration"]["starts"]
    rms = [v[0] for _, v in e["/plots/icp/rms_mm"].timed("Scalars:scalars", "icp")]
    assert rms[-1] == pytest.approx(results["registration"]["rms_m"] * 1e3, rel=0.2)
    # The cell is held at the registration's moment on the icp timeline.
    held = e["/world/cell/table"].timed("Transform3D:translation", "icp")
    assert [i for i, _ in held] == [0]
