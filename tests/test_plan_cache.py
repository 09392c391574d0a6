"""The disk cache of scan plans (scenarios.offline.plan_cache): a plan read back is the one
stored, to the bit, from a file read without pickle; any input of the virtual cell changes
its key; turned off it writes nothing; a damaged, cut, foreign or old file is reported and
planned anew."""

from __future__ import annotations

import ast
import logging
import pickle
from dataclasses import fields, is_dataclass, replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pydantic import BaseModel

from cell.irb2400_arm import irb2400
from models.mesh import TriangleMesh
from models.model import ObjectModel
from scenarios.configuration.config_files import load_config
from scenarios.configuration.job_config import JobConfig
from scenarios.offline import plan_cache
from scenarios.offline.scan_candidates import Candidate
from scenarios.offline.scan_choice import ChosenPass
from scenarios.offline.scan_passes import PlannedPass
from scenarios.offline.scan_plan import ScanPlan
from scenarios.offline.settings import ScanPass


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
    assert (cache_dir / "plans" / "k1.npz").is_file()
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
    assert not list(cache_dir.rglob("*.npz"))


def test_a_caller_turns_it_off_for_its_own_use(cache_dir: Path) -> None:
    """`use_cache=False` (`twincell run --no-cache`): planned each time, nothing written."""
    calls: list[int] = []

    def plan() -> ScanPlan:
        calls.append(1)
        return _plan(1e-4)

    for _ in range(2):
        assert plan_cache.cached_plan("k3", plan, use_cache=False)[1] is False
    assert calls == [1, 1]
    assert not list(cache_dir.rglob("*.npz"))


def _same(a: object, b: object, where: str = "plan") -> None:
    """a and b are the same tree of values, to the bit: types, arrays' dtypes and shapes."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray)
        assert (a.dtype, a.shape) == (b.dtype, b.shape), where
        assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{k}]")
    elif is_dataclass(a):
        for f in fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, BaseModel):
        assert a == b, where
    else:
        assert a == b, (where, a, b)


def _full_plan() -> ScanPlan:
    """A plan holding every kind of value a plan's tree has: passes with and without a
    planned table frame and via joints, candidates with their ScanPass, an infinite TRE, a
    stand-off of its own and none, the points each pass sees."""
    rng = np.random.default_rng(3)
    T = np.eye(4)
    T[:3, 3] = rng.normal(size=3)
    first = PlannedPass("pass 1", T, T @ T, 0.125, rng.normal(size=6))
    second = PlannedPass("pass 2", T.T, T, -0.3, rng.normal(size=6), T * 2,
                         (rng.normal(size=6), rng.normal(size=6)))  # fmt: skip
    chosen = (
        ChosenPass("pass 1", 30.0, 45.0, 0.01, None, 0.125, float("inf"), 4.5, 0.7),
        ChosenPass("pass 2", -50.0, 180.0, -0.02, 0.31, -0.3, 2.1e-4, 6.25, 0.3),
    )
    candidates = tuple(
        Candidate(ScanPass(tilt_deg=t, heading_deg=h, standoff_m=s), planned,
                  rng.normal(size=(n, 3)), rng.normal(size=(n, 3)).astype(np.float32), 3.5 + n)
        for (t, h, s), planned, n in zip(((30.0, 45.0, None), (-50.0, 180.0, 0.31)),
                                         (first, second), (17, 5), strict=True)
    )  # fmt: skip
    seen = (rng.normal(size=(9, 3)), np.zeros((0, 3)))
    return ScanPlan("auto", (first, second), 10.75, np.array([2.1e-4, np.inf]), chosen,
                    candidates, 0.05, seen, 0.3)  # fmt: skip


def test_a_plan_round_trip_is_the_same_tree_to_the_bit(cache_dir: Path) -> None:
    plan = _full_plan()
    path = cache_dir / "full.npz"
    path.write_bytes(plan_cache.encode_plan(plan))
    _same(plan, plan_cache.read_plan(path))
    first, stored = plan_cache.cached_plan("full", _full_plan)
    again, stored_again = plan_cache.cached_plan("full", lambda: pytest.fail("planned again"))
    assert (stored, stored_again) == (False, True)
    _same(first, again)


def test_a_planned_fixed_scan_round_trips(cache_dir: Path) -> None:
    """The skull job's own fixed plan, as the planner makes it, reads back the same."""
    from scenarios.jobs.job_plan import job_robot, object_models
    from scenarios.offline.nominal_placement import nominal_pose
    from scenarios.offline.operations import target_operations
    from scenarios.stages.scan_stage import job_scan_plan

    config = load_config("skull", {"localization.scan.plan": "fixed"})
    assert isinstance(config, JobConfig)
    settings = config.planning()
    virtual, _ = object_models(config)
    T = nominal_pose(settings.placement, virtual.mesh.vertices)
    ops = target_operations(virtual, config.operations)
    targets = np.array([op.T_object_touch[:3, 3] for op in ops])
    plan = job_scan_plan(job_robot(config.cell.robot), settings, virtual, T, targets,
                         lambda _m: None, tuple(op.name for op in ops))  # fmt: skip
    path = cache_dir / "skull.npz"
    path.write_bytes(plan_cache.encode_plan(plan))
    _same(plan, plan_cache.read_plan(path))


def test_a_damaged_file_is_planned_anew_and_replaced(cache_dir: Path, caplog) -> None:
    path = cache_dir / "plans" / "k3.npz"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"not a plan")
    with caplog.at_level(logging.WARNING, logger=plan_cache.__name__):
        plan, stored = plan_cache.cached_plan("k3", lambda: _plan(2e-4))
    assert stored is False and plan.predicted_tre_m[0] == 2e-4
    assert [r.levelname for r in caplog.records] == ["WARNING"]
    assert f"{path}: not a readable plan" in caplog.text and "planning anew" in caplog.text
    caplog.clear()
    again, stored_again = plan_cache.cached_plan("k3", lambda: _plan(9.0))
    assert stored_again is True and again.predicted_tre_m[0] == 2e-4
    assert not caplog.records  # a good file: nothing to report


def _tree_file(path: Path, plan: ScanPlan, edit) -> None:
    """The plan's file with its JSON tree changed by `edit(text) -> text`."""
    with np.load(path.parent / "good.npz", allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["tree"] = np.array(edit(str(arrays["tree"])))
    with path.open("wb") as f:
        np.savez(f, **arrays)


@pytest.mark.parametrize(
    ("damage", "why"),
    [
        ("cut", "not a readable plan (BadZipFile"),
        ("stale layout", "layout 1, this code reads 2"),
        ("foreign type", "not a readable plan (KeyError: 'Popen'"),
        ("other fields", "a ChosenPass with other fields"),
        ("bad json", "not a readable plan (JSONDecodeError"),
    ],
)
def test_a_cut_stale_or_foreign_file_is_reported_and_rebuilt(
    cache_dir: Path, caplog, damage: str, why: str
) -> None:
    folder = cache_dir / "plans"
    folder.mkdir()
    good = plan_cache.encode_plan(_full_plan())
    (folder / "good.npz").write_bytes(good)
    path = folder / "k4.npz"
    if damage == "cut":
        path.write_bytes(good[: len(good) // 2])
    elif damage == "stale layout":
        with np.load(folder / "good.npz", allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files} | {"format": np.array(1)}
        with path.open("wb") as f:
            np.savez(f, **arrays)
    elif damage == "foreign type":
        _tree_file(path, _full_plan(), lambda t: t.replace('"ScanPlan"', '"Popen"', 1))
    elif damage == "other fields":
        _tree_file(path, _full_plan(), lambda t: t.replace('"information_share"', '"share"'))
    else:
        _tree_file(path, _full_plan(), lambda t: t[:-5])
    with caplog.at_level(logging.WARNING, logger=plan_cache.__name__):
        plan, stored = plan_cache.cached_plan("k4", lambda: _plan(5e-4))
    assert stored is False and plan.predicted_tre_m[0] == 5e-4
    assert f"scan plan cache: {path}" in caplog.text and why in caplog.text, caplog.text
    assert plan_cache.cached_plan("k4", lambda: _plan(9.0))[0].predicted_tre_m[0] == 5e-4


def test_an_old_pickled_plan_is_never_opened(cache_dir: Path, caplog) -> None:
    """A plan pickled by the former layout (`.pickle`) under the same key is ignored: the
    cache neither unpickles it nor reports it; the plan is made and stored as .npz."""
    folder = cache_dir / "plans"
    folder.mkdir()
    (folder / "k5.pickle").write_bytes(pickle.dumps(_plan(9.0)))
    with caplog.at_level(logging.WARNING, logger=plan_cache.__name__):
        plan, stored = plan_cache.cached_plan("k5", lambda: _plan(1e-4))
    assert stored is False and plan.predicted_tre_m[0] == 1e-4
    assert not caplog.records and (folder / "k5.npz").is_file()


def test_the_cache_imports_no_pickle() -> None:
    tree = ast.parse(Path(plan_cache.__file__).read_text())
    imported = {a.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for a in node.names}  # fmt: skip
    imported |= {node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    assert not {name for name in imported if "pickle" in name}, imported
    assert "allow_pickle=True" not in Path(plan_cache.__file__).read_text()
