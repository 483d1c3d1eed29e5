"""First use of the compiled kernels: the wall time and peak memory of numba's compilation, per kernel.

A fresh process with ``NUMBA_CACHE_DIR`` an empty folder (what a fresh clone and every CI run meet) imports the
kernels' modules, then makes each kernel's first call, in the order a study makes them: the stuck modes of two
designs (``nonlinear.stuck_modes.stuck_designs`` with ``nonlinear.dense_linear_algebra``), then QSMA of two
designs at five levels for each of the ASB's friction models in turn (``nonlinear.qsma_kernel.solve_levels``;
the first model compiles it, the others show whether they add a specialisation). A second process with the same
folder, now holding numba's on-disk cache, repeats every step: what every later run pays. Each step's time is wall
clock, its memory the process's peak resident memory at its end (the process's, so a step's peak includes those
before it). The structure is the ASB C1 superelement of the measured data, or the BRB's from ``build/rom`` where
that is absent.

Run: ``python -m benchmarks.compile`` (about a minute here).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from benchmarks import ASB_MODELS
from benchmarks.table import row, show

ROM = Path("build/rom/BRB.npz")
MODELS = ("jenkins", "iwan4", "iwan5", "iwan4_core")  # the ASB study's, in its order
N_DESIGNS = 2
LEVELS = 5


def peak_mib() -> float:
    """This process's peak resident memory so far, MiB (ru_maxrss in kB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def steps() -> Iterator[tuple[str, float, float]]:
    """(step, wall time s, peak memory MiB) of each step of the module docstring, in this process."""
    start = time.perf_counter()
    import numpy as np

    from nonlinear.condensation import StuckModeCache, joint_space, modal_split
    from nonlinear.joint import patch_elements, random_designs, stuck_stiffness, tangential_rows
    from nonlinear.qsma_vectorised import qsma_designs
    from reduction.superelement import beam_superelement, read_asb_superelement
    yield "import", time.perf_counter() - start, peak_mib()

    asb = ASB_MODELS / "MAT_NULLRED_C1.mat"
    superelement = (read_asb_superelement(asb, patch_groups=(0, 0, 0, 0)) if asb.is_file()
                    else beam_superelement(ROM))
    space = joint_space(superelement)
    split = modal_split(space)
    n_groups = max(superelement.patch_groups) + 1
    rng = np.random.default_rng(0)
    amplitudes = np.geomspace(1e-6, 1e-4, LEVELS)
    start = time.perf_counter()
    elements = patch_elements("iwan4", random_designs("iwan4", N_DESIGNS, n_groups, rng), superelement.patch_groups)
    StuckModeCache(space, split, tangential_rows(superelement.n_patches))(stuck_stiffness(elements))
    yield "stuck modes, first call", time.perf_counter() - start, peak_mib()
    for model in MODELS:
        start = time.perf_counter()
        qsma_designs(space, model, random_designs(model, N_DESIGNS, n_groups, rng), amplitudes=amplitudes,
                     split=split)
        yield f"QSMA {model}, first call", time.perf_counter() - start, peak_mib()


def child() -> None:
    """Print one JSON line per step (``steps``)."""
    for name, seconds, peak in steps():
        print(json.dumps({"step": name, "seconds": seconds, "peak_mib": peak}), flush=True)


def run_child(cache: Path) -> list[dict]:
    """The steps in a fresh process whose numba cache is ``cache``."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    result = subprocess.run([sys.executable, "-m", "benchmarks.compile", "--child"], env=environment,
                            capture_output=True, text=True, check=True)
    return [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]


def rows() -> Iterator[dict]:
    """A row per step, cold cache then warm (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as folder:
        for label in ("cold cache", "warm cache"):
            start = time.perf_counter()
            measured = run_child(Path(folder))
            whole = time.perf_counter() - start
            for step in measured:
                yield row("compile", f"{step['step']}, {label}", step["seconds"], step["peak_mib"],
                          note="wall time of the step; the process's peak resident memory at its end")
            yield row("compile", f"whole process, {label}", whole, max(s["peak_mib"] for s in measured),
                      note="start to exit, interpreter start and imports included")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    if parser.parse_args(argv).child:
        child()
    else:
        show(rows(), [f"first use of the compiled kernels, {os.cpu_count()} cores"])


if __name__ == "__main__":
    main()
