"""A worker process among others on one machine: its numeric libraries' thread pools sized to
its share of the cores.

NumPy's and SciPy's OpenBLAS and the OpenMP runtime each start as many threads as the machine
has cores. Two worker processes on two cores (a campaign's, pytest-xdist's) then run four to
six busy threads that take the cores from each other: a skull job took 19.5 s in each of two
workers against 13-15 s alone, and 15 s once each worker kept to its share.
"""

from __future__ import annotations

import os

#: The variables the libraries read when they load (OpenMP, OpenBLAS, MKL).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def share_cores(workers: int) -> int | None:
    """Size this process's thread pools to its share of the cores among `workers` processes
    (at least one thread): the libraries loaded already through threadpoolctl, those loaded
    later through THREAD_VARIABLES. A user's own setting of any of those variables is kept
    (nothing changed: None). Returns the threads per pool."""
    if any(name in os.environ for name in THREAD_VARIABLES):
        return None
    threads = max(1, (os.cpu_count() or 1) // max(1, workers))
    for name in THREAD_VARIABLES:
        os.environ[name] = str(threads)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads)
    return threads
