"""QSMA levels on a CUDA GPU against the CPU kernel: equality and designs per second, one run, one table.

Run as ``python -m benchmarks.gpu_qsma OUT [--designs N] [--levels L] [--structures ...] [--models ...]
[--workers W]`` on a machine with a GPU (numba-cuda and the CUDA libraries of the project's ``gpu`` extra). For
every structure (the beams of ``build/rom``, the ASB's CD1 where its reduced model is found) and friction model,
N random Table 3 designs at L modal amplitudes over the ASB's measured range (amplitude control) are evaluated by
``nonlinear.qsma_vectorised.qsma_designs`` twice: with device="cpu" in W processes (default: every core), each a
contiguous share of the designs, and with device="cuda", all designs in one launch. Checked per level: the
status (the reason) equal, and omega and zeta equal within 1e-10 relative where converged. A design whose first
differing level follows levels that all agree is a branch difference at a flag (a decision at a threshold that
the two round-offs straddle: libdevice's exp2, log2 and pow and NVVM's fused multiply-adds are not the CPU's);
one whose numbers drift apart first is a defect. Timed: the levels alone (``solve_levels``: the CPU kernel in
each process, summed over the processes' wall times / W for the all-core rate, and the GPU call with its
transfers) and the whole evaluation's wall time (the stuck modes are on the CPU, one process, for the GPU run);
the GPU's first call (numba-cuda's compile, about a minute) is made on two designs before timing. Writes
``OUT/gpu_qsma.json`` (every measurement, the branch differences' status pairs) and ``OUT/gpu_qsma.md`` (the
table). Sized for 16 cores and an H100 within about 8 minutes (not yet run on a GPU); with NUMBA_ENABLE_CUDASIM=1 at a tiny size
(``--designs 3 --levels 4 --structures BRB --workers 1``) it runs in numba-cuda's simulator, without a GPU.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks import ASB_MODELS  # noqa: E402
from nonlinear import qsma_vectorised  # noqa: E402
from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.friction_models import MODEL_NAMES  # noqa: E402
from nonlinear.joint import random_designs  # noqa: E402
from reduction.superelement import beam_superelement, read_asb_superelement  # noqa: E402

AMPLITUDE_RANGE = (7e-6, 1.1e-4)  # m kg^0.5, the measured ASB backbones (as benchmarks.qsma)
RELATIVE = 1e-10  # omega and zeta of a converged level: GPU against CPU
ROM = Path("build/rom")
SEED = 40


@functools.cache
def structure_space(name: str):
    """The joint space of a beam's default-mesh superelement in build/rom, or of the ASB configuration
    ("ASB CD1"); once per process."""
    if name.startswith("ASB "):
        return joint_space(read_asb_superelement(ASB_MODELS / f"MAT_NULLRED_{name.split()[1]}.mat"))
    return joint_space(beam_superelement(ROM / f"{name}.npz"))


def available_structures() -> list[str]:
    """The beams whose superelement is in build/rom, and the ASB's CD1 where its reduced model is found."""
    names = [beam for beam in ("BRB", "LBRB", "SBRB") if (ROM / f"{beam}.npz").exists()]
    return names + (["ASB CD1"] if (ASB_MODELS / "MAT_NULLRED_CD1.mat").exists() else [])


def timed_levels(device: str) -> tuple:
    """The device's ``solve_levels`` wrapped to add its wall time (s) to the returned list's single entry."""
    solve, seconds = qsma_vectorised.level_solver(device), [0.0]

    def timed(*arguments):
        start = time.perf_counter()
        result = solve(*arguments)
        seconds[0] += time.perf_counter() - start
        return result

    return timed, seconds


def evaluate(structure: str, model: str, designs: np.ndarray, amplitudes: np.ndarray, device: str) -> tuple:
    """QSMA of ``designs`` on ``device``: (frequency, damping, reason as str) each (n, L), the levels' seconds and
    the whole call's."""
    timed, seconds = timed_levels(device)
    original = qsma_vectorised.level_solver
    qsma_vectorised.level_solver = lambda _: timed
    try:
        start = time.perf_counter()
        result = qsma_vectorised.qsma_designs(structure_space(structure), model, designs, amplitudes=amplitudes,
                              linear_damping=1e-3, device=device)
        total = time.perf_counter() - start
    finally:
        qsma_vectorised.level_solver = original
    return result.frequency, result.damping, result.reason.astype(str), seconds[0], total


def n_groups(structure: str) -> int:
    """The structure's number of patch groups (a design's width)."""
    return max(structure_space(structure).superelement.patch_groups) + 1


def cpu_share(task: tuple) -> tuple:
    """``evaluate`` on the CPU of one process's share (a worker's task)."""
    return evaluate(*task, "cpu")


def compared(cpu: tuple, gpu: tuple) -> dict:
    """Per-level comparison: the largest relative difference of omega and of zeta where both converged, the levels
    whose reason differs, and the designs with one, split into branch differences at a flag (every earlier level
    equal within RELATIVE) and drifts, with the (cpu, gpu) reason pairs of the first differing level."""
    frequency = np.abs(gpu[0] / cpu[0] - 1.0)
    damping = np.abs(gpu[1] / cpu[1] - 1.0)
    same_reason = cpu[2] == gpu[2]
    close = same_reason & ((frequency <= RELATIVE) & (damping <= RELATIVE) | np.isnan(cpu[0]) & np.isnan(gpu[0]))
    both = same_reason & np.isfinite(cpu[0]) & np.isfinite(gpu[0])
    pairs, flags, drifts = Counter(), 0, 0
    for design in np.flatnonzero(~close.all(axis=1)):
        first = int(np.argmin(close[design]))
        pairs[f"{cpu[2][design, first] or 'converged'} | {gpu[2][design, first] or 'converged'}"] += 1
        if same_reason[design, first]:
            drifts += 1
        else:
            flags += 1
    return {"omega": float(frequency[both].max(initial=0.0)), "zeta": float(damping[both].max(initial=0.0)),
            "levels": int(cpu[0].size), "reasons_differ": int((~same_reason).sum()),
            "flagged": int((cpu[2] != "").sum()), "branch_at_flag": flags, "drift": drifts, "pairs": dict(pairs)}


def measure(structure: str, model: str, n_designs: int, amplitudes: np.ndarray, pool, workers: int) -> dict:
    """One structure and model: the GPU against the CPU kernel on the same designs."""
    designs = random_designs(model, n_designs, n_groups(structure), np.random.default_rng(SEED))
    shares = np.array_split(designs, workers)
    start = time.perf_counter()
    parts = list(pool.map(cpu_share, [(structure, model, share, amplitudes) for share in shares]))
    cpu_wall = time.perf_counter() - start
    cpu = tuple(np.concatenate([part[k] for part in parts]) for k in range(3))
    cpu_levels = sum(part[3] for part in parts) / workers
    gpu = evaluate(structure, model, designs, amplitudes, "cuda")
    return {"structure": structure, "model": model, "designs": n_designs,
            "cpu_levels_per_s": n_designs / cpu_levels, "gpu_levels_per_s": n_designs / gpu[3],
            "cpu_per_s": n_designs / cpu_wall, "gpu_per_s": n_designs / gpu[4], **compared(cpu, gpu)}


def table(rows: list[dict], workers: int) -> list[str]:
    """The markdown table of the measurements."""
    lines = [f"| structure | model | designs | levels/s CPU ({workers} proc.) | levels/s GPU | ratio | "
             "whole/s CPU | whole/s GPU | max rel omega | max rel zeta | reasons differ | at flag | drift |",
             "|" + "---|" * 13]
    for r in rows:
        lines.append(f"| {r['structure']} | {r['model']} | {r['designs']} | {r['cpu_levels_per_s']:.0f} | "
                     f"{r['gpu_levels_per_s']:.0f} | {r['gpu_levels_per_s'] / r['cpu_levels_per_s']:.2f} | "
                     f"{r['cpu_per_s']:.0f} | {r['gpu_per_s']:.0f} | {r['omega']:.1e} | {r['zeta']:.1e} | "
                     f"{r['reasons_differ']} of {r['levels']} | {r['branch_at_flag']} | {r['drift']} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="folder for gpu_qsma.json and gpu_qsma.md")
    parser.add_argument("--designs", type=int, default=10000)
    parser.add_argument("--levels", type=int, default=20)
    parser.add_argument("--structures", nargs="+", default=None, help="default: " + " ".join(available_structures()))
    parser.add_argument("--models", nargs="+", default=list(MODEL_NAMES), choices=MODEL_NAMES)
    parser.add_argument("--workers", type=int, default=os.cpu_count())
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    amplitudes = np.geomspace(*AMPLITUDE_RANGE, args.levels)
    structures = args.structures or available_structures()
    warm = random_designs(args.models[0], 2, n_groups(structures[0]), np.random.default_rng(0))
    rows = []
    # spawned workers: none inherits the GPU context of this process
    with ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(cpu_share, [(structures[0], args.models[0], warm, amplitudes)] * args.workers))
        start = time.perf_counter()
        evaluate(structures[0], args.models[0], warm, amplitudes, "cuda")  # numba-cuda compiles the kernel
        compile_seconds = time.perf_counter() - start
        print(f"GPU kernel compiled and run on 2 designs: {compile_seconds:.1f} s", flush=True)
        for structure in structures:
            for model in args.models:
                rows.append(measure(structure, model, args.designs, amplitudes, pool, args.workers))
                print(table(rows[-1:], args.workers)[-1], flush=True)
    lines = table(rows, args.workers)
    print("\n".join(lines))
    (args.out / "gpu_qsma.md").write_text("\n".join(lines) + "\n")
    (args.out / "gpu_qsma.json").write_text(json.dumps(
        {"compile_seconds": compile_seconds, "levels": args.levels, "workers": args.workers,
         "relative": RELATIVE, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
