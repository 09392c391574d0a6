"""How many CPUs a worker process counts (scenarios.workers.usable_cpus): those it may run on,
capped by its container's CPU quota as cgroup v1 and v2 write it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import threadpoolctl

from scenarios import workers


def _cgroups(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, v2: str | None, v1: tuple[str, str] | None
) -> None:
    cpu_max = tmp_path / "cpu.max"
    quota, period = tmp_path / "cfs_quota_us", tmp_path / "cfs_period_us"
    if v2 is not None:
        cpu_max.write_text(v2 + "\n")
    if v1 is not None:
        quota.write_text(v1[0] + "\n")
        period.write_text(v1[1] + "\n")
    monkeypatch.setattr(workers, "_CPU_MAX", cpu_max)
    monkeypatch.setattr(workers, "_CFS", (quota, period))
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(8)))


@pytest.mark.parametrize(
    ("v2", "v1", "expected"),
    [
        (None, None, 8),  # no quota: the eight CPUs the process may run on
        ("max 100000", None, 8),  # v2, no quota
        ("200000 100000", None, 2),  # v2: `docker run --cpus 2`
        ("150000 100000", None, 1),  # 1.5 CPUs: one worker keeps busy within it
        ("50000 100000", None, 1),  # less than one: still one
        ("1600000 100000", None, 8),  # a quota above the affinity: the affinity
        (None, ("-1", "100000"), 8),  # v1, no quota
        (None, ("300000", "100000"), 3),  # v1: three CPUs
        ("garbage", None, 8),  # unreadable: no quota assumed
    ],
)
def test_usable_cpus_is_the_affinity_capped_by_the_quota(
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    v2: str | None,
    v1: tuple[str, str] | None,
    expected: int,
) -> None:
    _cgroups(monkeypatch, tmp_path, v2, v1)
    assert workers.usable_cpus() == expected


def test_share_cores_divides_the_usable_cpus(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Two workers under a quota of four CPUs on an eight-CPU affinity: two threads each,
    set for the libraries loaded later too (the pools loaded already are asked through
    threadpoolctl, stood in for here so that this test's worker keeps its own); a user's own
    setting is kept."""
    _cgroups(monkeypatch, tmp_path, "400000 100000", None)
    limits: list[int] = []
    monkeypatch.setattr(threadpoolctl, "threadpool_limits", lambda limits_: limits.append(limits_))
    for name in workers.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    assert workers.share_cores(2) == 2
    assert limits == [2]
    assert all(os.environ[name] == "2" for name in workers.THREAD_VARIABLES)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    assert workers.share_cores(2) is None
