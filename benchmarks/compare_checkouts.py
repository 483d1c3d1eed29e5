"""The study's exploration in two checkouts of the project, side by side: the same designs' rows and their speed.

Run as ``python -m benchmarks.compare_checkouts REFERENCE [--designs N] [--repeats R]`` from this checkout, REFERENCE
the root of another (e.g. the main branch's). For every model the rows of one chunk of N designs on the three
beams of ``benchmarks.study`` (``study.exploration.chunk_tables``: QSMA, errors, converged flags and reasons) are
computed by each checkout in its own process (its own modules on the path; the kernels compiled and loaded
first), alternating reference and this checkout, each the best of R timings of the chunk (CPU time of the process,
``time.process_time``, BLAS single-threaded). Printed per model: each checkout's design evaluations (designs x
beams) per CPU-second, their ratio, the largest difference of every error column relative to the column's
largest magnitude (NaN where not converged, which must match) and the number of designs whose converged flag
or reason differs. Exit status 1 where any flag or reason differs.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402

SEED = 5
HERE = Path(__file__).resolve().parents[1]


def evaluate(model: str, n_designs: int, repeats: int, table_path: Path) -> float:
    """One chunk of ``n_designs`` designs of ``model`` on the three beams with the checkout on the path: its rows
    written to ``table_path`` (Parquet), and the best of ``repeats`` CPU times of the chunk (s)."""
    import time

    from benchmarks.study import DAMPING_CASES, beams
    from study.exploration import Exploration, Sample, chunk_tables, process_splits

    structures = beams()
    exploration = Exploration(structures, (model,), Sample(seed=SEED, n_designs=n_designs, chunk_size=n_designs),
                              DAMPING_CASES)
    splits = process_splits(exploration)
    chunk_tables(Exploration(structures, (model,), Sample(seed=SEED + 1, n_designs=20, chunk_size=20),
                             DAMPING_CASES), 0, splits=splits)  # compile and load the kernels first
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        table = chunk_tables(exploration, 0, splits=splits)[model]
        best = min(best, time.process_time() - start)
    pq.write_table(table, table_path)
    return best


def run_checkout(root: Path, model: str, n_designs: int, repeats: int, table_path: Path) -> float:
    """``evaluate`` in a fresh process whose only project modules are those of the checkout at ``root`` (this file
    run with -P: its own folder not on the path)."""
    environment = dict(os.environ, PYTHONPATH=str(root))
    output = subprocess.run([sys.executable, "-P", __file__, "--worker", model, str(n_designs), str(repeats),
                             str(table_path)], env=environment, cwd=HERE, check=True, capture_output=True, text=True)
    return json.loads(output.stdout.splitlines()[-1])["seconds"]


def differences(reference, candidate) -> tuple[float, int, int]:
    """Largest difference of the error and stuck-frequency columns relative to each column's largest magnitude,
    the number of (design, beam) pairs whose NaN pattern or converged flag differs, and whose reason differs."""
    largest, flags, reasons = 0.0, 0, 0
    for name in reference.column_names:
        if not (name.startswith(("frequency_error", "damping_error", "stuck_frequency", "converged", "reason"))):
            continue
        a, b = reference[name].to_numpy(zero_copy_only=False), candidate[name].to_numpy(zero_copy_only=False)
        if name.startswith("reason"):
            reasons += int(np.count_nonzero(a != b))
        elif name.startswith("converged"):
            flags += int(np.count_nonzero(a != b))
        else:
            flags += int(np.count_nonzero(np.isnan(a) != np.isnan(b)))
            both = np.isfinite(a) & np.isfinite(b)
            if both.any():
                largest = max(largest, float(np.max(np.abs(a[both] - b[both])) / max(np.max(np.abs(a[both])), 1e-300)))
    return largest, flags, reasons


def compare(reference_root: Path, n_designs: int, repeats: int) -> bool:
    """Print the module docstring's table for every model; True where no flag or reason differs."""
    from nonlinear.friction_models import MODEL_NAMES

    same = True
    print(f"{'model':12s} {'reference /s':>13s} {'this /s':>10s} {'speed-up':>9s} {'max rel diff':>13s} "
          f"{'flags':>6s} {'reasons':>8s}")
    with tempfile.TemporaryDirectory() as folder:
        for model in MODEL_NAMES:
            paths = Path(folder) / f"{model}-reference.parquet", Path(folder) / f"{model}-this.parquet"
            reference_seconds = run_checkout(reference_root, model, n_designs, repeats, paths[0])
            seconds = run_checkout(HERE, model, n_designs, repeats, paths[1])
            largest, flags, reasons = differences(pq.read_table(paths[0]), pq.read_table(paths[1]))
            evaluations = 3 * n_designs
            print(f"{model:12s} {evaluations / reference_seconds:13.0f} {evaluations / seconds:10.0f} "
                  f"{reference_seconds / seconds:9.3f} {largest:13.2e} {flags:6d} {reasons:8d}", flush=True)
            same = same and flags == 0 and reasons == 0
    return same


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference", nargs="?", type=Path, help="root of the other checkout")
    parser.add_argument("--designs", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--worker", nargs=4, metavar=("MODEL", "N", "R", "TABLE"), help=argparse.SUPPRESS)
    arguments = parser.parse_args(argv)
    if arguments.worker:
        model, n_designs, repeats, table = arguments.worker
        print(json.dumps({"seconds": evaluate(model, int(n_designs), int(repeats), Path(table))}))
        return 0
    if arguments.reference is None:
        parser.error("give the root of the reference checkout")
    return 0 if compare(arguments.reference.resolve(), arguments.designs, arguments.repeats) else 1


if __name__ == "__main__":
    sys.exit(main())
