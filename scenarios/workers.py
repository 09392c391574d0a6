"""A worker process among others on one machine: its numeric libraries' thread pools sized to
its share of the cores.

NumPy's and SciPy's OpenBLAS and the OpenMP runtime each start as many threads as the machine
has cores. Two worker processes on two cores (a campaign's, pytest-xdist's) then run four to
six busy threads that take the cores from each other: a skull job took 19.5 s in each of two
workers against 13-15 s alone, and 15 s once each worker kept to its share.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

#: The variables the libraries read when they load (OpenMP, OpenBLAS, MKL).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def share_cores(workers: int) -> int | None:
    """Size this process's thread pools to its share of the cores among `workers` processes
    (at least one thread): the libraries loaded already through threadpoolctl, those loaded
    later through THREAD_VARIABLES. A user's own setting of any of those variables is kept
    (nothing changed: None). Returns the threads per pool."""
    if any(name in os.environ for name in THREAD_VARIABLES):
        return None
    threads = max(1, usable_cpus() // max(1, workers))
    for name in THREAD_VARIABLES:
        os.environ[name] = str(threads)
    from threadpoolctl import threadpool_limits

    threadpool_limits(threads)
    return threads


def usable_cpus() -> int:
    """The CPUs this process may keep busy: those it may run on (its affinity), capped by
    its container's CPU quota (cgroup v2's cpu.max, v1's cfs quota: `docker run --cpus`),
    at least one. `os.cpu_count()` counts the host's, which a container or a job scheduler
    may not give; psutil's physical count, which pytest-xdist's `-n auto` takes, counts a
    core with two hardware threads once."""
    count = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    quota = _cgroup_quota()
    if quota is not None:
        count = min(count or 1, max(1, math.floor(quota)))
    return max(1, count or 1)


#: Where a container sees its own CPU quota: cgroup v2's "QUOTA PERIOD" (or "max PERIOD"),
#: v1's quota and period [us] (-1: none).
_CPU_MAX = Path("/sys/fs/cgroup/cpu.max")
_CFS = (Path("/sys/fs/cgroup/cpu/cpu.cfs_quota_us"), Path("/sys/fs/cgroup/cpu/cpu.cfs_period_us"))


def _cgroup_quota() -> float | None:
    """The CPU quota of this process's cgroup in CPUs, or None (none set, or unreadable)."""
    try:
        if _CPU_MAX.is_file():
            quota, period = _CPU_MAX.read_text().split()[:2]
            return None if quota == "max" else int(quota) / int(period)
        if _CFS[0].is_file():
            quota_us, period_us = (int(path.read_text()) for path in _CFS)
            return None if quota_us <= 0 else quota_us / period_us
    except (OSError, ValueError, ZeroDivisionError):
        return None  # unreadable: no quota assumed
    return None
