"""The disk cache of scan plans (scenarios.offline.plan_cache): a plan read back is the one
stored, to the bit; any input of the virtual cell changes its key; turned off it writes
nothing; a damaged file is planned anew."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cell.robots import irb2400
from models.mesh import TriangleMesh
from models.model import ObjectModel
from scenarios.jobs.config import load_config
from scenarios.offline import plan_cache
from scenarios.offline.scan_plan import ScanPlan


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("TWINCELL_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TWINCELL_NO_CACHE", raising=False)
    return tmp_path


def _plan(tre: float) -> ScanPlan:
    return ScanPlan("fixed", (), 12.5, np.array([tre, 2.0 * tre]), ())


def _virtual(shift_m: float = 0.0) -> ObjectModel:
    box = trimesh.creation.box((0.1, 0.08, 0.05))
    return ObjectModel(
        name="block",
        mesh=TriangleMesh(np.asarray(box.vertices) + shift_m, box.faces),
        convex_pieces=(),
    )


def _key(**change: object) -> str:
    settings = load_config("skull", {}, None).planning()
    robot = irb2400()
    inputs: dict[str, object] = {
        "robot": robot,
        "settings": settings,
        "virtual": _virtual(),
        "T_table_object": np.eye(4),
        "targets_model": np.zeros((2, 3)),
        "target_names": ("a", "b"),
    }
    inputs.update(change)
    return plan_cache.plan_key(**inputs)  # type: ignore[arg-type]


def test_a_plan_read_back_is_the_one_stored(cache_dir: Path) -> None:
    calls: list[int] = []

    def plan() -> ScanPlan:
        calls.append(1)
        return _plan(3.0e-4)

    first, stored_first = plan_cache.cached_plan("k1", plan)
    second, stored_second = plan_cache.cached_plan("k1", plan)
    assert (stored_first, stored_second) == (False, True)
    assert calls == [1]  # planned once, then read
    assert (cache_dir / "plans" / "k1.pickle").is_file()
    assert second.predicted_time_s == first.predicted_time_s == 12.5
    assert np.array_equal(second.predicted_tre_m, np.array([3.0e-4, 6.0e-4]))


def test_every_input_of_the_virtual_cell_is_in_the_key() -> None:
    base = _key()
    settings = load_config("skull", {}, None).planning()
    moved = load_config("skull", {"localization.scan.speed_m_s": 0.05}, None).planning()
    assert settings.model_dump_json() != moved.model_dump_json()
    other_home = replace(irb2400(), q_home=irb2400().q_home + 1e-6)
    changed = {
        "settings": _key(settings=moved),
        "robot": _key(robot=other_home),
        "mesh": _key(virtual=_virtual(1e-9)),
        "pose": _key(T_table_object=np.diag([1.0, 1.0, 1.0, 1.0]) + 1e-12),
        "targets": _key(targets_model=np.full((2, 3), 1e-9)),
        "names": _key(target_names=("a", "c")),
    }
    assert _key() == base  # the same inputs, the same key
    for what, key in changed.items():
        assert key != base, what
    assert len(set(changed.values())) == len(changed)


def test_turned_off_it_plans_and_writes_nothing(
    cache_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWINCELL_NO_CACHE", "1")
    calls: list[int] = []

    def plan() -> ScanPlan:
        calls.append(1)
        return _plan(1e-4)

    for _ in range(2):
        assert plan_cache.cached_plan("k2", plan)[1] is False
    assert calls == [1, 1]
    assert not list(cache_dir.rglob("*.pickle"))


def test_a_damaged_file_is_planned_anew_and_replaced(cache_dir: Path) -> None:
    path = cache_dir / "plans" / "k3.pickle"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"not a plan")
    plan, stored = plan_cache.cached_plan("k3", lambda: _plan(2e-4))
    assert stored is False and plan.predicted_tre_m[0] == 2e-4
    again, stored_again = plan_cache.cached_plan("k3", lambda: _plan(9.0))
    assert stored_again is True and again.predicted_tre_m[0] == 2e-4
