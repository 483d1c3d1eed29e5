"""Benchmark of the study's exploration: design evaluations per second per core, errors and Parquet included.

Run as ``python -m benchmarks.study [--designs N] [--chunk C]``. The three beams' superelements (build/rom, from
``make rom``) with a virtual measurement with a known answer (``study.structures.qsma_measurement`` of one
iwan4 design, 20 levels from 1e-7 to 3e-5 m kg^0.5: the linear range deep into microslip) are explored by
``study.exploration.explore`` exactly as ``surrogacy study`` does: designs regenerated from the seed, QSMA on
every beam, the errors for three linear damping cases, one Parquet file per chunk written atomically. The table
gives per model the CPU time of the process (``time.process_time``, one core, BLAS single-threaded), the design
evaluations (designs x beams) per CPU-second, the projection of the paper's full scale (5 x 10^6 designs x 3
beams per model) on two such cores, and the peak resident memory of the process. The full scale is projected
from this rate, not measured (it would take most of an hour here).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.joint import FRICTION_MODELS  # noqa: E402
from study.exploration import Exploration, Sample, explore  # noqa: E402
from study.structures import beam_superelement, qsma_measurement, structure  # noqa: E402

ROM = Path("build/rom")
BEAMS = ("BRB", "LBRB", "SBRB")
TRUE_DESIGN = np.array([4e3, 2e8, -0.4, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 5e9, 8e3, 4e8, -0.5, 0.3, 5e9])
LEVELS = np.geomspace(1e-7, 3e-5, 20)
DAMPING_CASES = {"BRB": [1.6659e-3] * 3, "LBRB": [9.243e-4] * 3, "SBRB": [9.461e-4] * 3}
PAPER_DESIGNS = 5e6


def beams():
    """The three beams with the known-answer virtual measurement."""
    structures = []
    for beam in BEAMS:
        superelement = beam_superelement(ROM / f"{beam}.npz")
        measured = qsma_measurement(joint_space(superelement), beam, "iwan4", TRUE_DESIGN, LEVELS, 1.6659e-3)
        structures.append(structure(beam, superelement, measured, 0.0, len(LEVELS)))
    return tuple(structures)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=4000, help="designs per model")
    parser.add_argument("--chunk", type=int, default=1000, help="designs per chunk")
    arguments = parser.parse_args(argv)
    if not all((ROM / f"{beam}.npz").exists() for beam in BEAMS):
        print(f"study benchmark: {ROM} lacks the beams' superelements (run `make rom`); skipped")
        return
    structures = beams()
    sample = Sample(seed=1, n_designs=arguments.designs, chunk_size=arguments.chunk)
    warm = Exploration(structures, FRICTION_MODELS, Sample(seed=2, n_designs=50, chunk_size=50), DAMPING_CASES)
    print(f"Study benchmark: {arguments.designs} designs per model on {len(BEAMS)} beams, {len(LEVELS)} levels, "
          f"chunks of {arguments.chunk}, errors and Parquet included, one core")
    print(f"{'model':<12} {'CPU s':>8} {'evaluations/s':>14} {'paper scale on 2 cores':>23} {'peak RSS':>9}")
    with tempfile.TemporaryDirectory() as folder:
        explore(warm, Path(folder) / "warm", progress=False)  # compile and load the kernels first
        for model in FRICTION_MODELS:
            exploration = Exploration(structures, (model,), sample, DAMPING_CASES)
            start = time.process_time()
            explore(exploration, Path(folder) / model, progress=False)
            seconds = time.process_time() - start
            rate = arguments.designs * len(BEAMS) / seconds
            full_scale = PAPER_DESIGNS * len(BEAMS) / (2 * rate) / 60
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(f"{model:<12} {seconds:>8.2f} {rate:>14.0f} {full_scale:>19.0f} min {peak:>6.0f} MB")


if __name__ == "__main__":
    main()
