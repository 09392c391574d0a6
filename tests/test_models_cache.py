"""The disk cache of the skull phantom (models.cache): what it reads back is the built model
to the bit; turned off (by the environment, or by a caller) it writes nothing; a damaged
file is built anew."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from models import cache, registry
from models.model import ObjectModel
from models.registry import _skull


def _same(a: ObjectModel, b: ObjectModel) -> None:
    def exact(x: np.ndarray, y: np.ndarray) -> None:
        assert x.dtype == y.dtype and np.array_equal(x, y)

    exact(a.mesh.vertices, b.mesh.vertices)
    exact(a.mesh.faces, b.mesh.faces)
    assert len(a.convex_pieces) == len(b.convex_pieces) > 0
    for p, q in zip(a.convex_pieces, b.convex_pieces, strict=True):
        exact(p.vertices, q.vertices)
        exact(p.faces, q.faces)
    assert [h.name for h in a.burr_holes] == [h.name for h in b.burr_holes]
    for h, k in zip(a.burr_holes, b.burr_holes, strict=True):
        exact(h.p_entry, k.p_entry)
        exact(h.direction, k.direction)
        assert h.depth == k.depth
    assert (a.name, a.source) == (b.name, b.source)


@pytest.fixture(scope="module")
def built() -> ObjectModel:
    return _skull(3)  # the builder itself: the ground truth


def test_the_cached_skull_is_the_built_one(
    built: ObjectModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWINCELL_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TWINCELL_NO_CACHE", raising=False)
    calls: list[int] = []

    def build(seed: int) -> ObjectModel:
        calls.append(seed)
        return built

    first = cache.cached("skull", 3, build)
    (stored,) = tmp_path.glob("*.npz")
    assert stored.name == f"{cache.key('skull', 3)}.npz" == f"{cache.used_key('skull', 3)}.npz"
    second = cache.cached("skull", 3, build)
    assert calls == [3]  # built once, then read
    _same(built, first)
    _same(built, second)
    assert not second.mesh.vertices.flags.writeable


def test_turned_off_it_builds_and_writes_nothing(
    built: ObjectModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWINCELL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("TWINCELL_NO_CACHE", "1")
    assert cache.cached("skull", 3, lambda seed: built) is built
    assert not list(tmp_path.iterdir())
    assert cache.used_key("skull", 3) is None


def test_a_caller_turns_it_off_for_its_own_use(
    built: ObjectModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`use_cache=False` (`twincell run --no-cache`) through the registry: built, nothing
    written, no key; the process's other uses keep the cache."""
    monkeypatch.setenv("TWINCELL_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TWINCELL_NO_CACHE", raising=False)
    monkeypatch.setitem(registry._BUILDERS, "skull", lambda seed: built)
    registry._cached.cache_clear()
    try:
        assert registry.builtin_model("skull", 3, use_cache=False) is built
        assert not list(tmp_path.iterdir())
        assert cache.used_key("skull", 3, use_cache=False) is None
        _same(built, registry.builtin_model("skull", 3))
        assert [p.name for p in tmp_path.iterdir()] == [f"{cache.used_key('skull', 3)}.npz"]
    finally:
        registry._cached.cache_clear()  # the stand-in builder's models are not the skull's


def test_a_damaged_file_is_built_anew(
    built: ObjectModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWINCELL_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TWINCELL_NO_CACHE", raising=False)
    (tmp_path / f"{cache.key('skull', 3)}.npz").write_bytes(b"not a zip")
    _same(built, cache.cached("skull", 3, lambda seed: built))
    _same(built, cache.cached("skull", 3, lambda seed: pytest.fail("built twice")))


def test_the_key_follows_the_generators_code(monkeypatch: pytest.MonkeyPatch) -> None:
    before = cache.key("skull", 3)
    monkeypatch.setattr(cache, "code_hash", lambda: "0123456789abcdef")
    assert cache.key("skull", 3) != before and cache.key("skull", 3) != cache.key("skull", 4)
    assert cache.used_key("bracket", 3) is None  # a model built in milliseconds is not kept
