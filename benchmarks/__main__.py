"""``make bench``: one table of every stage's benchmark, printed row by row and written to results/bench.

Stages, in order: geometry (each beam meshed), fem (each beam's FE steps and CalculiX beside them; coarse meshes
by default, ``--fem-meshes default`` for the default meshes: the run then nears 30 min), reduction (each beam's
superelement from build/fe), qsma and study (designs per second per core per friction model, the paper-scale
study projected and the one measured earlier), analysis (the analyse step's pass over N and 4 N synthetic designs:
wall time and peak memory, flat in N), calibration (time and evaluations per ASB configuration and
model), surrogacy (subset simulation against brute force for SC at tightening bounds), discrepancy (the one-mode
loop's Jacobian batched against one evaluation per column, and whole loops with their fits counted), dask (serial
against LocalClusters of 1 and 2 workers), gpu (where a CUDA GPU is: each friction model on the GPU against the CPU
kernels on every core, and the exploration on both; ``benchmarks.gpu_check``), and last the wall time of the whole
run. The table
(``benchmarks.table``) is also written to ``<out>/bench.md`` and ``<out>/bench.csv``.
Run: ``python -m benchmarks [--fem-meshes coarse|default] [--out results/bench]``.
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import os
import time
from pathlib import Path

from benchmarks import (analysis, calibration, dask_speedup, discrepancy, fem, geometry, gpu_check, qsma, reduction,
                        study, surrogacy_confidence)
from benchmarks.table import row, show, write


def _whole_run(start: float):
    """The last row, made when every other row is measured: wall time (s) since ``start`` (perf_counter)."""
    yield row("bench", "whole run", time.perf_counter() - start, note="wall time of every row above")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fem-meshes", choices=("coarse", "default"), default="coarse",
                        help="meshes of the FE benchmark (coarse: about 3.5 min here; default: more than 17 min)")
    parser.add_argument("--out", type=Path, default=Path("results/bench"), help="folder of bench.md, bench.csv")
    arguments = parser.parse_args(argv)
    start = time.perf_counter()
    preamble = [f"`make bench`, {datetime.date.today()}, {os.cpu_count()} cores, OPENBLAS_NUM_THREADS="
                f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}; other work may share the machine, so the "
                f"timings are noisy (+-10 % or more); FE on {arguments.fem_meshes} meshes"]
    stages = itertools.chain(geometry.rows(), fem.rows(coarse=arguments.fem_meshes == "coarse"), reduction.rows(),
                             qsma.rows(), study.rows(), analysis.rows(), calibration.rows(), surrogacy_confidence.rows(),
                             discrepancy.rows(), dask_speedup.rows(), gpu_check.rows())
    rows = show(itertools.chain(stages, _whole_run(start)), preamble)
    markdown, table = write(rows, arguments.out, preamble)
    print(f"{rows[-1]['seconds']:.0f} s in all; table written to {markdown} and {table}")


if __name__ == "__main__":
    main()
