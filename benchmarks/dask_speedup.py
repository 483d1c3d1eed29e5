"""Benchmark of the study on Dask: the same small exploration serially and on LocalClusters of 1 and 2 workers.

Run as ``python -m benchmarks.dask_speedup [--designs N] [--chunk C] [--repeats R]``. The exploration of
``benchmarks.study`` (the three beams' superelements from build/rom, errors and Parquet included), all four
friction models, N designs each in chunks of C, is run by ``study.exploration.explore`` in one process (serial)
and on a dask.distributed LocalCluster of 1 and of 2 worker processes of one thread each, as
``surrogacy study --scheduler local`` runs it. Each set-up runs in a fresh process (``benchmarks.peak``); the
cluster's start and the kernels' compilation (a small exploration on every worker first) are not timed. The
time is the wall clock of the exploration, the best of R runs; the speed-up is the serial time over the
set-up's, measured in the same benchmark run; the parallel efficiency of 2 workers is the 1-worker time over
twice the 2-worker time. Each run's idle share of the worker threads (``study.exploration.Explored.idle_fraction``:
the time outside evaluating and writing chunks, first submission to last file) is in the note. The peak memory
is that of the process driving the study; the workers' peak is in the note.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import logging  # noqa: E402
import resource  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

from benchmarks.peak import measure  # noqa: E402
from benchmarks.study import DAMPING_CASES, LEVELS, ROM, beams  # noqa: E402
from geometry.parameters import BEAM_NAMES  # noqa: E402
from benchmarks.table import row, show  # noqa: E402
from nonlinear.friction_models import MODEL_NAMES  # noqa: E402
from pipeline.runners import SERIAL, Dask, local_cluster  # noqa: E402
from study.exploration import Exploration, Sample, explore  # noqa: E402

SETUPS = (("serial, this process", None), ("LocalCluster, 1 worker", 1), ("LocalCluster, 2 workers", 2))


@contextlib.contextmanager
def _runner(workers: int | None):
    """``SERIAL``, or a ``Dask`` runner on a LocalCluster of ``workers`` single-threaded worker processes, started
    as the study starts it (``pipeline.runners.local_cluster``)."""
    if workers is None:
        yield SERIAL
        return
    from distributed import Client

    with (local_cluster(workers, dashboard_address=None, silence_logs=logging.ERROR) as cluster,
          Client(cluster) as client):
        yield Dask(client)


def _warm(exploration: Exploration, folder: str) -> None:
    """Explore a small sample in this process (a worker, or the serial process): compiles and loads the kernels."""
    explore(exploration, Path(folder) / f"warm-{os.getpid()}", progress=False)


def _peak_mib() -> float:
    """Peak resident memory of this process (a worker), MiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def timed_exploration(workers: int | None, n_designs: int, chunk: int,
                      repeats: int) -> tuple[float, float, float | None]:
    """Explore N designs of every model serially (workers None) or on a LocalCluster of ``workers``; returns the
    shortest wall time of ``repeats`` explorations (s), that run's idle share of the worker threads and the
    workers' largest peak memory (MiB; None serially)."""
    structures = beams()
    warm = Exploration(structures, MODEL_NAMES, Sample(seed=2, n_designs=50, chunk_size=50), DAMPING_CASES)
    runs = []
    with tempfile.TemporaryDirectory() as folder, _runner(workers) as runner:
        if workers is None:
            _warm(warm, folder)
        else:
            runner.client.run(_warm, warm, folder)
        for repeat in range(repeats):
            # a sample of its own each time: the same study submitted again on one client (same task and data
            # keys) was cancelled with "lost dependencies" here
            sample = Sample(seed=1 + repeat, n_designs=n_designs, chunk_size=chunk)
            exploration = Exploration(structures, MODEL_NAMES, sample, DAMPING_CASES)
            start = time.perf_counter()
            run = explore(exploration, Path(folder) / f"run-{repeat}", runner, progress=False)
            runs.append((time.perf_counter() - start, run.idle_fraction))
        seconds, idle = min(runs)
        return seconds, idle, max(runner.client.run(_peak_mib).values()) if workers else None


def rows(n_designs: int = 10_000, chunk: int = 2500, repeats: int = 2) -> Iterator[dict]:
    """A row per set-up (``SETUPS``): wall time (s), peak memory of the driving process (MiB) and the speed-up
    over the serial run."""
    if not all((ROM / f"{beam}.npz").exists() for beam in BEAM_NAMES):
        yield row("dask", "all set-ups", note=f"skipped: {ROM} lacks the beams' superelements (run `make rom`)")
        return
    evaluations = n_designs * len(MODEL_NAMES) * len(BEAM_NAMES)
    setting = (f"{n_designs:,} designs x {len(MODEL_NAMES)} models x {len(BEAM_NAMES)} beams x {len(LEVELS)} levels "
               f"in chunks of {chunk:,}, wall clock, best of {repeats}")
    times = {}
    for name, workers in SETUPS:
        _, peak, (seconds, idle, worker_peak) = measure(timed_exploration, workers, n_designs, chunk, repeats)
        times[workers] = seconds
        throughput = f"{evaluations / seconds:,.0f} evaluations/s, threads idle {idle:.1%}"
        if workers is None:
            yield row("dask", name, seconds, peak, note=f"{setting}: {throughput}")
            continue
        versus_one = (f", {times[1] / seconds:.2f} x 1 worker (parallel efficiency {times[1] / (workers * seconds):.0%})"
                      if workers > 1 else "")
        yield row("dask", name, seconds, peak, times[None] / seconds, "x serial",
                  f"{throughput}{versus_one}; threads per worker 1, workers' peak {worker_peak:,.0f} MiB")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=10_000, help="designs per model")
    parser.add_argument("--chunk", type=int, default=2500, help="designs per chunk")
    parser.add_argument("--repeats", type=int, default=2, help="timed explorations per set-up; the shortest counts")
    arguments = parser.parse_args(argv)
    show(rows(arguments.designs, arguments.chunk, arguments.repeats))


if __name__ == "__main__":
    main()
