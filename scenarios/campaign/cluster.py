"""Cluster backend: Dask distributed, on a running scheduler or on a local cluster.

Dask distributed is pure Python from PyPI (a few MB, installs in seconds), a local cluster of
two worker processes starts in a few seconds, and pointing the same code at a real cluster is
one address: start `dask scheduler` on one host and `dask worker tcp://HOST:8786` on each
node (each with twincell installed), then pass `--scheduler tcp://HOST:8786`.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Sequence

from scenarios.campaign.campaign_errors import CampaignError
from scenarios.campaign.trials import Trial, run_trial
from scenarios.results.edge import JsonObject

OnRow = Callable[[JsonObject], None]


def run_dask(
    trials: Sequence[Trial], on_row: OnRow, scheduler: str | None = None, workers: int = 2
) -> None:
    """Run `trials` on the Dask scheduler at `scheduler` (e.g. "tcp://10.0.0.5:8786"), or on
    a local cluster of `workers` single-threaded processes when no address is given. Rows
    come back to this process as they finish and go to `on_row`, once per trial: a worker
    that dies mid-trial has its trial run again elsewhere by Dask (up to its
    `allowed-failures`), and a row once collected is released from the cluster."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:  # pragma: no cover - a dependency of the package
        raise CampaignError(f"the dask backend needs dask[distributed]: {exc}") from None
    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout="20s")
            except OSError as exc:
                raise CampaignError(
                    f"cannot reach the Dask scheduler {scheduler!r}: {exc}"
                ) from None
        else:
            cluster = LocalCluster(
                n_workers=max(1, workers),
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
            client = Client(cluster)
        token = uuid.uuid4().hex[:8]
        with client:
            pending = {
                future.key: future
                for future in (
                    client.submit(run_trial, t, key=f"trial-{t.trial_id}-{token}", pure=False)
                    for t in trials
                )
            }
            try:
                for future in as_completed(list(pending.values())):
                    on_row(future.result())
                    # Stored here: the cluster may forget the row, so that a worker lost
                    # later has no finished trial of it to run again.
                    del pending[future.key]
                    future.release()
            except BaseException:
                client.cancel(list(pending.values()))
                raise
    finally:
        if cluster is not None:
            cluster.close()
