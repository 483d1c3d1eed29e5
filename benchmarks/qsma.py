"""Benchmark of the vectorised QSMA: design evaluations per second per core for each friction model.

Run as ``python -m benchmarks.qsma [--designs N] [--levels L] [--repeats R] [--configuration CD1] [--models ...]``.
Each design is evaluated at L modal amplitudes (amplitude control, log-spaced over the ASB's measured range) on
one core (BLAS limited to one thread). A row per model gives the CPU time of the process (``time.process_time``,
so other work on the machine does not count; the compiled kernels are loaded before timing; the shortest of
``--repeats`` runs, the models taking turns within each, since contention for a shared machine's caches still
lengthens it, by +-10 % from one minute to the next here), designs per CPU-second, the CPU time per design split
into the condensation (element parameters and the stuck modes, ``nonlinear.condensation.stuck_modes``, timed
alone) and the rest (the levels: the compiled kernel), and the share of designs with at least one level not
converged, by reason. A second row per model measures what a projection from the single-core rate assumes:
``--processes`` processes (default 2, the cores here) evaluating designs at the same time, their wall-clock
throughput per process (cores share caches and memory bandwidth, so this is below the single-core rate).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import multiprocessing  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.table import row, show  # noqa: E402
from nonlinear.condensation import joint_space, modal_split, stuck_modes  # noqa: E402
from nonlinear.friction_models import MODEL_NAMES  # noqa: E402
from nonlinear.joint import patch_elements, random_designs, stuck_stiffness, tangential_rows  # noqa: E402
from nonlinear.qsma_vectorised import qsma_designs  # noqa: E402
from benchmarks import ASB_MODELS  # noqa: E402
from reduction.superelement import read_asb_superelement  # noqa: E402

AMPLITUDE_RANGE = (7e-6, 1.1e-4)  # m kg^0.5, the measured ASB backbones
CHUNK = 1000  # designs per vectorised call


def _evaluated(model: str, space, designs, amplitudes, split):
    """QSMA of ``designs`` in chunks of CHUNK, as the benchmark times it: yields each chunk's result."""
    for first in range(0, len(designs), CHUNK):
        yield qsma_designs(space, model, designs[first:first + CHUNK], amplitudes=amplitudes, linear_damping=1e-3,
                           split=split)


def _timed_pass(model: str, space, designs, amplitudes, split) -> tuple:
    """One pass over ``designs``: the CPU time of the whole evaluation, the CPU time of the condensation alone
    (element parameters and stuck modes, as ``qsma_designs`` forms them) and the designs not converged, by
    reason."""
    rows = tangential_rows(space.superelement.n_patches)
    reasons = Counter()
    start = time.process_time()
    for result in _evaluated(model, space, designs, amplitudes, split):
        failed = ~result.converged.all(axis=1)
        reasons.update(next(reason for reason in row if reason) for row in result.reason[failed])
    seconds = time.process_time() - start
    start = time.process_time()
    for first in range(0, len(designs), CHUNK):
        elements = patch_elements(model, designs[first:first + CHUNK], space.superelement.patch_groups)
        stuck_modes(space, stuck_stiffness(elements), split, rows)
    return seconds, time.process_time() - start, reasons


def benchmark(models, space, n_designs: int, n_levels: int, repeats: int = 1, seed: int = 0) -> list:
    """Evaluate ``n_designs`` random Table 3 designs of each model ``repeats`` times, the models in turn within
    each repetition (so that a busy spell of a shared machine slows every model alike); per model, the shortest
    CPU time (other processes only ever lengthen it), the shortest CPU time of the condensation alone and the
    non-convergence counts."""
    n_groups = max(space.superelement.patch_groups) + 1
    amplitudes = np.geomspace(*AMPLITUDE_RANGE, n_levels)
    split = modal_split(space)
    designs = {model: random_designs(model, n_designs, n_groups, np.random.default_rng(seed)) for model in models}
    for model in models:  # load the compiled kernels
        qsma_designs(space, model, designs[model][:2], amplitudes=amplitudes, split=split)
    seconds = dict.fromkeys(models, np.inf)
    condensation_seconds = dict.fromkeys(models, np.inf)
    reasons = {}
    for _ in range(repeats):
        for model in models:
            total, condensation, reasons[model] = _timed_pass(model, space, designs[model], amplitudes, split)
            seconds[model] = min(seconds[model], total)
            condensation_seconds[model] = min(condensation_seconds[model], condensation)
    return [{"model": model, "designs": n_designs, "seconds": seconds[model], "rate": n_designs / seconds[model],
             "condensation": condensation_seconds[model] / n_designs,
             "levels": (seconds[model] - condensation_seconds[model]) / n_designs,
             "failed": sum(reasons[model].values()) / n_designs, "reasons": reasons[model]} for model in models]


def _timed_share(model: str, configuration: str, n_designs: int, n_levels: int, repeats: int, seed: int,
                 barrier) -> list:
    """One process's share of the parallel measurement: load the model and compile, then ``repeats`` times wait
    for the other processes and evaluate ``n_designs`` designs; returns the wall-clock (start, end) of each
    pass in seconds since the epoch."""
    space = joint_space(read_asb_superelement(ASB_MODELS / f"MAT_NULLRED_{configuration}.mat"))
    n_groups = max(space.superelement.patch_groups) + 1
    designs = random_designs(model, n_designs, n_groups, np.random.default_rng(seed))
    amplitudes = np.geomspace(*AMPLITUDE_RANGE, n_levels)
    split = modal_split(space)
    qsma_designs(space, model, designs[:2], amplitudes=amplitudes, split=split)
    spans = []
    for _ in range(repeats):
        barrier.wait()
        start = time.time()
        for _ in _evaluated(model, space, designs, amplitudes, split):
            pass
        spans.append((start, time.time()))
    return spans


def parallel_rate(model: str, configuration: str, n_designs: int, n_levels: int, processes: int,
                  repeats: int = 1) -> float:
    """Designs per wall-clock second of ``processes`` processes evaluating ``n_designs`` designs each at the
    same time (different seeds), from the first start to the last end; the best of ``repeats`` passes."""
    context = multiprocessing.get_context("spawn")
    with context.Manager() as manager, ProcessPoolExecutor(processes, mp_context=context) as pool:
        barrier = manager.Barrier(processes)
        shares = list(pool.map(_timed_share, *zip(*[(model, configuration, n_designs, n_levels, repeats, seed,
                                                     barrier) for seed in range(processes)])))
    return max(processes * n_designs / (max(span[1] for span in spans) - min(span[0] for span in spans))
               for spans in zip(*shares))


def rows(models=MODEL_NAMES, n_designs: int = 4000, n_levels: int = 30, repeats: int = 5,
         processes: int = 2, configuration: str = "CD1") -> Iterator[dict]:
    """The rows of the module docstring: per model its single-core rate (designs per CPU-second), then per model
    its rate per process with ``processes`` processes at once (designs per wall-clock second)."""
    path = ASB_MODELS / f"MAT_NULLRED_{configuration}.mat"
    if not path.exists():
        yield row("qsma", "all models", note=f"skipped: no ASB reduced model {path}")
        return
    space = joint_space(read_asb_superelement(path))
    setting = (f"{n_designs:,} designs x {n_levels} levels, ASB {configuration} ({space.superelement.n_patches} "
               f"patches, {len(space.eigenvalues)} modes)")
    for result in benchmark(models, space, n_designs, n_levels, repeats):
        reasons = "; ".join(f"{reason}: {count}" for reason, count in result["reasons"].items()) or "-"
        yield row("qsma", f"{result['model']}, 1 core", result["seconds"],
                  resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, result["rate"], "designs/s/core",
                  f"{setting}, CPU time, best of {repeats}; us/design: condensation "
                  f"{1e6 * result['condensation']:.1f} + levels {1e6 * result['levels']:.1f}; not converged "
                  f"{100 * result['failed']:.2f} % ({reasons})")
    for model in models:
        rate = parallel_rate(model, configuration, n_designs, n_levels, processes, repeats)
        yield row("qsma", f"{model}, {processes} processes", processes * n_designs / rate, rate=rate / processes,
                  unit="designs/s/core", note=f"{processes} processes at once, {n_designs:,} designs each, wall "
                                             f"clock, best of {repeats}: {rate:,.0f} designs/s together")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=4000)
    parser.add_argument("--levels", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=5, help="timed repetitions; the shortest counts")
    parser.add_argument("--processes", type=int, default=2, help="processes of the parallel measurement")
    parser.add_argument("--configuration", default="CD1", help="ASB reduced model (five patches: CD1)")
    parser.add_argument("--models", nargs="+", default=list(MODEL_NAMES), choices=MODEL_NAMES)
    arguments = parser.parse_args(argv)
    show(rows(arguments.models, arguments.designs, arguments.levels, arguments.repeats, arguments.processes,
              arguments.configuration))


if __name__ == "__main__":
    main()
