"""Campaigns past one machine: the same tasks on an existing Dask cluster
(``shoal campaign --dask ADDRESS``, docs/campaign.md).

Each field is one Dask task running exactly what a local worker runs (``run_task`` or
``run_people_task``): the field is drawn from its seed on the worker and simulated there, so
the outcomes are the local run's, field for field (tests/tools/test_cluster.py, with a local cluster
of two worker processes). Every worker needs this shoal installed (the same version: the bits
of a field are the code's); the scheduler needs nothing of shoal. Dask's ``distributed`` is an
optional dependency (``pip install 'shoal[cluster]'``); the local process pool stays the
default and needs nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

CONNECT_TIMEOUT_S = 10.0


class ClusterError(RuntimeError):
    """The cluster cannot be used: ``distributed`` missing, or no scheduler at the address."""


def run_on_dask(
    todo: Sequence[T], address: str, done: Callable[[R], None], work: Callable[[T], R]
) -> tuple[list[R], int]:
    """``work`` on every task on the Dask cluster at ``address``, ``done`` called as each
    finishes; the outcomes in task order, and the cluster's worker threads."""
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise ClusterError(
            "--dask needs Dask's distributed package: pip install 'shoal[cluster]'"
        ) from exc
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"no Dask scheduler at {address}: {exc}") from None
    with client:
        threads = sum(client.nthreads().values())
        if threads == 0:
            raise ClusterError(f"the Dask scheduler at {address} has no workers")
        futures = client.map(work, list(todo), pure=False)
        order = {f.key: k for k, f in enumerate(futures)}
        by_index: dict[int, R] = {}
        try:
            for future in as_completed(futures):
                by_index[order[future.key]] = outcome = future.result()
                done(outcome)
        except BaseException:
            client.cancel(futures)  # Ctrl-C, or a field's bug: nothing left running
            raise
    return [by_index[k] for k in range(len(todo))], threads
