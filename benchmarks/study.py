"""Benchmark of the study's exploration: design evaluations per second per core, errors and Parquet included.

Run as ``python -m benchmarks.study [--designs N] [--chunk C]``. The three beams' superelements (build/rom, from
``make rom``) with a virtual measurement with a known answer (``study.structures.qsma_measurement`` of one
iwan4 design, 20 levels from 1e-7 to 3e-5 m kg^0.5: the linear range deep into microslip) are explored by
``study.exploration.explore`` exactly as ``surrogacy study`` does: designs regenerated from the seed, QSMA on
every beam, the errors for three linear damping cases, one Parquet file per chunk written atomically. A row per
model gives the CPU time of the process (``time.process_time``, one core, BLAS single-threaded), the design
evaluations (designs x beams) per CPU-second, and the peak resident memory of the process so far; then the paper's
four models explored together, as the study explores them (one task per chunk for every model, the stuck modes
formed once for the models with the same stuck joint), and its ratio to the models one by one. Then the paper's
full scale (5 x 10^6 designs x 3 beams per model, four models) projected from the together rate on two such cores,
and beside it the full-scale run measured once (``MEASURED_FULL_SCALE``; not repeated by the benchmark: it takes
a quarter of an hour here).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.table import row, show  # noqa: E402
from geometry.parameters import BEAM_NAMES  # noqa: E402
from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.friction_models import MODEL_NAMES, models_for  # noqa: E402
from study.exploration import Exploration, Sample, explore  # noqa: E402
from reduction.superelement import beam_superelement  # noqa: E402
from study.structures import qsma_measurement, structure  # noqa: E402

ROM = Path("build/rom")
TRUE_DESIGN = np.array([4e3, 2e8, -0.4, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 5e9, 8e3, 4e8, -0.5, 0.3, 5e9])
LEVELS = np.geomspace(1e-7, 3e-5, 20)
DAMPING_CASES = {"BRB": [1.6659e-3] * 3, "LBRB": [9.243e-4] * 3, "SBRB": [9.461e-4] * 3}
PAPER_DESIGNS = 5e6  # per beam and model (paper section 4.3)
PAPER_MODELS = models_for(3, in_paper=True)  # the paper's four friction models
CORES = 2  # of the machine the projection is for
MEASURED_FULL_SCALE = row(
    "study", "paper scale, measured 2026-11-26", 917, 1414,
    note="15 min 17 s, NOT measured by this run: the explore step of `surrogacy study --scheduler local`, 5,000,000 "
         "designs per model, 4 models together, 3 beams, chunks of 5,000 written by two workers, this 2-core machine; "
         "wall time, peak resident memory of the whole process tree (the whole command with the measurements, analysis "
         "and report: 17 min 21 s)")


def beams():
    """The three beams with the known-answer virtual measurement."""
    structures = []
    for beam in BEAM_NAMES:
        superelement = beam_superelement(ROM / f"{beam}.npz")
        measured = qsma_measurement(joint_space(superelement), beam, "iwan4", TRUE_DESIGN, LEVELS, 1.6659e-3)
        structures.append(structure(beam, superelement, measured, 0.0, len(LEVELS)))
    return tuple(structures)


def explored_seconds(exploration: Exploration, folder: Path) -> float:
    """CPU time (s) of this process exploring ``exploration`` into ``folder``, serially."""
    start = time.process_time()
    explore(exploration, folder, progress=False)
    return time.process_time() - start


def rows(n_designs: int = 4000, chunk: int = 1000) -> Iterator[dict]:
    """The rows of the module docstring: per model its exploration rate (evaluations per CPU-second), the
    projected paper scale on ``CORES`` cores (s) and the measured one."""
    if not all((ROM / f"{beam}.npz").exists() for beam in BEAM_NAMES):
        yield row("study", "all models", note=f"skipped: {ROM} lacks the beams' superelements (run `make rom`)")
        yield MEASURED_FULL_SCALE
        return
    structures = beams()
    sample = Sample(seed=1, n_designs=n_designs, chunk_size=chunk)
    warm = Exploration(structures, MODEL_NAMES, Sample(seed=2, n_designs=50, chunk_size=50), DAMPING_CASES)
    alone = 0.0
    with tempfile.TemporaryDirectory() as folder:
        explore(warm, Path(folder) / "warm", progress=False)  # compile and load the kernels first
        for model in MODEL_NAMES:
            seconds = explored_seconds(Exploration(structures, (model,), sample, DAMPING_CASES), Path(folder) / model)
            alone += seconds if model in PAPER_MODELS else 0.0
            yield row("study", model, seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                      n_designs * len(BEAM_NAMES) / seconds, "evaluations/s/core",
                      f"{n_designs:,} designs x {len(BEAM_NAMES)} beams x {len(LEVELS)} levels, chunks of {chunk:,}, "
                      "errors and Parquet included, CPU time")
        together = explored_seconds(Exploration(structures, PAPER_MODELS, sample, DAMPING_CASES),
                                    Path(folder) / "together")
    rate = n_designs * len(BEAM_NAMES) * len(PAPER_MODELS) / together
    yield row("study", "paper models together", together, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
              rate, "evaluations/s/core", f"{', '.join(PAPER_MODELS)} in one exploration (the stuck modes shared): "
                                          f"{alone / together:.2f} x their rows above one by one")
    projected = PAPER_DESIGNS * len(BEAM_NAMES) * len(PAPER_MODELS) / (CORES * rate)
    yield row("study", "paper scale, projected", projected,
              note=f"{projected / 60:.0f} min: {PAPER_DESIGNS:,.0f} designs x {len(BEAM_NAMES)} beams x "
                   f"{len(PAPER_MODELS)} models at the together rate on {CORES} cores, perfect scaling assumed "
                   f"(dask rows: the real scaling)")
    yield MEASURED_FULL_SCALE


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=4000, help="designs per model")
    parser.add_argument("--chunk", type=int, default=1000, help="designs per chunk")
    arguments = parser.parse_args(argv)
    show(rows(arguments.designs, arguments.chunk))


if __name__ == "__main__":
    main()
