"""Local backend: K worker processes on this machine (one process: run in this process)."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait

from scenarios.campaign.trials import Trial, run_trial
from scenarios.results.edge import JsonObject
from scenarios.workers import share_cores

OnRow = Callable[[JsonObject], None]


def run_local(trials: Sequence[Trial], workers: int, on_row: OnRow) -> None:
    """Run `trials` on `workers` processes, handing each row to `on_row` as it finishes
    (in this process, so that one writer stores the results). Spawned workers keep their
    cached models across trials; an interrupt cancels the trials not yet started."""
    if workers <= 1:
        for trial in trials:
            on_row(run_trial(trial))
        return
    context = multiprocessing.get_context("spawn")  # no fork of a threaded parent
    with ProcessPoolExecutor(
        max_workers=workers, mp_context=context, initializer=share_cores, initargs=(workers,)
    ) as pool:
        pending: set[Future[JsonObject]] = set()
        queue = list(reversed(trials))
        try:
            # Keep at most 2 trials per worker queued: an interrupt loses little work.
            while queue or pending:
                while queue and len(pending) < 2 * workers:
                    pending.add(pool.submit(run_trial, queue.pop()))
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    on_row(future.result())
        except BaseException:
            for future in pending:
                future.cancel()
            pool.shutdown(wait=False, cancel_futures=True)
            raise
