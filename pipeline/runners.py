"""One way to run independent tasks: in this process, on worker processes of this machine, or on a dask.distributed
cluster (a LocalCluster or a running scheduler). The caller chooses the runner and passes it in; the library calls
it and never asks which one it is. A task's result depends on its arguments only, so every runner gives the same
numbers.

A runner has
    slots                          how many tasks run at once (a batch is cut into that many pieces)
    share(value)                   a large argument sent to the workers once; pass what it returns in its place
    map(function, tasks)           function(*task) for every task (a tuple of arguments), the results in order
    completed(function, tasks)     the same, the results as they finish, ``IN_FLIGHT_PER_SLOT`` tasks per slot in
                                   flight

Runners: ``SERIAL`` (this process), ``process_pool`` (spawned worker processes), ``Dask`` (a client's cluster);
``runner(scheduler)`` opens the one a ``--scheduler`` option names; ``worker_name`` tells code which dask worker
runs it.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from typing import Callable, Iterable, Iterator

IN_FLIGHT_PER_SLOT = 2
"""Tasks per slot kept in flight by ``completed`` on a cluster: the next one is queued while one runs."""
WORKER_ENVIRONMENT = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
"""dask's nannies start each worker with glibc's MALLOC_TRIM_THRESHOLD_=65536 (memory handed back to the system
eagerly), which costs the exploration 8-10 % of its CPU time (a chunk's temporary arrays are mapped and unmapped
again at every allocation; measured alternately in one process with and without it): the local cluster's workers
keep glibc's own threshold. Workers started with ``dask worker`` take it from their shell's MALLOC_TRIM_THRESHOLD_
where set."""


class Serial:
    """Every task in this process, one after the other."""

    slots = 1

    def share(self, value):
        return value

    def map(self, function: Callable, tasks: Iterable[tuple]) -> list:
        return [function(*task) for task in tasks]

    def completed(self, function: Callable, tasks: Iterable[tuple]) -> Iterator:
        return (function(*task) for task in tasks)


SERIAL = Serial()


def ignore_ctrl_c() -> None:
    """Initialiser of the pool's worker processes: Ctrl-C is the parent's to handle (exit 130, no traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _star(function_and_task):
    function, task = function_and_task
    return function(*task)


class Processes:
    """Worker processes of this machine (``process_pool``); a shared value travels with each task."""

    def __init__(self, pool, slots: int):
        self.pool, self.slots = pool, slots

    def share(self, value):
        return value

    def map(self, function: Callable, tasks: Iterable[tuple]) -> list:
        return self.pool.starmap(function, tasks)

    def completed(self, function: Callable, tasks: Iterable[tuple]) -> Iterator:
        return self.pool.imap_unordered(_star, ((function, task) for task in tasks))


@contextlib.contextmanager
def process_pool(workers: int | None = None):
    """A ``Processes`` runner of ``workers`` processes (default one per core). Spawned, not forked: the parent may
    hold threads (dask, pytest-xdist) whose locks a fork would copy. Left early (Ctrl-C, an error), the workers are
    terminated at once, their tasks unfinished."""
    slots = workers or os.cpu_count()
    pool = multiprocessing.get_context("spawn").Pool(slots, initializer=ignore_ctrl_c)
    try:
        yield Processes(pool, slots)
    except BaseException:
        pool.terminate()
        raise
    else:
        pool.close()
    finally:
        pool.join()


class Dask:
    """The workers of a dask.distributed ``client``: one slot per worker thread; shared values scattered to
    every worker once."""

    def __init__(self, client):
        self.client = client

    @property
    def slots(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    def share(self, value):
        return self.client.scatter(value, broadcast=True)

    def map(self, function: Callable, tasks: Iterable[tuple]) -> list:
        return self.client.gather([self.client.submit(function, *task, pure=False) for task in tasks])

    def completed(self, function: Callable, tasks: Iterable[tuple]) -> Iterator:
        from distributed import as_completed

        tasks = iter(tasks)
        stream = as_completed()

        def submit():
            task = next(tasks, None)
            if task is not None:
                stream.add(self.client.submit(function, *task, pure=False))

        for _ in range(IN_FLIGHT_PER_SLOT * self.slots):
            submit()
        for future in stream:
            yield future.result()
            submit()


def worker_name():
    """The name of the dask.distributed worker this code runs in (a LocalCluster names its workers 0, 1, ...), or
    None outside a worker."""
    try:
        from distributed import get_worker

        return get_worker().name
    except (ImportError, ValueError):  # no dask.distributed, or not in a worker
        return None


@contextlib.contextmanager
def local_cluster(n_workers: int | None = None, **options):
    """A dask.distributed LocalCluster of ``n_workers`` (default one per core) single-threaded worker processes
    with ``WORKER_ENVIRONMENT``; ``options`` go to LocalCluster."""
    import dask
    from distributed import LocalCluster

    with dask.config.set(WORKER_ENVIRONMENT), LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                                           processes=True, **options) as cluster:
        yield cluster


def on_this_machine(scheduler: str | None) -> bool:
    """Whether the runner a ``--scheduler`` option names evaluates on this machine (none, or ``local``)."""
    return not scheduler or scheduler == "local"


@contextlib.contextmanager
def runner(scheduler: str | None):
    """The runner a ``--scheduler`` option names: None or empty, ``SERIAL``; ``local``, a ``Dask`` runner on a
    ``local_cluster``; else a ``Dask`` runner on the scheduler at that address."""
    if not scheduler:
        yield SERIAL
        return
    from distributed import Client

    if scheduler == "local":
        with local_cluster() as cluster, Client(cluster) as client:
            yield Dask(client)
    else:
        with Client(scheduler) as client:
            yield Dask(client)
