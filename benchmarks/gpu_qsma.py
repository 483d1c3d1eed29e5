"""Stuck modes and QSMA levels on a CUDA GPU against the CPU kernels: equality and designs per second, one run, one
table.

Run as ``python -m benchmarks.gpu_qsma OUT [--designs N] [--levels L] [--structures ...] [--models ...]
[--workers W]`` on a machine with a GPU (numba-cuda and NVVM: the project's ``gpu`` extra). For every structure
(the beams of ``build/rom``, the ASB's CD1 where its reduced model is found) and friction model, N random Table 3
designs at L modal amplitudes over the ASB's measured range (amplitude control) are evaluated by
``nonlinear.qsma_vectorised.qsma_designs`` twice: with device="cpu" in W processes (default: every core), each a
contiguous share of the designs, and with device="cuda", all designs in one launch of each kernel. Checked: the
stuck frequency within 1e-10 relative and defined on both or neither; per level, the status (the reason) equal,
and omega and zeta equal within 1e-10 relative where converged. A design whose first differing level follows
levels that all agree is a branch difference at a flag (a decision at a threshold that the two round-offs
straddle: libdevice's exp2, log2 and pow and NVVM's fused multiply-adds are not the CPU's); one whose numbers
drift apart first is a defect. Timed: each kernel (``nonlinear.compute_devices``: the stuck modes and the levels;
on the CPU summed over the processes and divided by W for the all-core rate, on the GPU with its transfers) and
the whole evaluation's wall time; the GPU's first call (numba-cuda's compile, about a minute) is made on two
designs before timing. Batches: one call of B designs (``--batches``, default ``BATCHES``) on the first structure,
GPU against one CPU core in this process (best of three): where a GPU gains and where it loses (a calibration's
least-squares steps solve 2 (d + 1) designs a call, its screens thousands). Writes ``OUT/gpu_qsma.json`` (every
measurement, the branch differences' status pairs) and ``OUT/gpu_qsma.md`` (the tables). With
NUMBA_ENABLE_CUDASIM=1 at a tiny size (``--designs 3 --levels 4 --structures BRB --workers 1 --batches 1 2``) it
runs in numba-cuda's simulator, without a GPU.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks import ASB_MODELS  # noqa: E402
from nonlinear import compute_devices, qsma_vectorised  # noqa: E402
from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.friction_models import MODEL_NAMES  # noqa: E402
from nonlinear.joint import random_designs  # noqa: E402
from reduction.superelement import beam_superelement, read_asb_superelement  # noqa: E402

AMPLITUDE_RANGE = (7e-6, 1.1e-4)  # m kg^0.5, the measured ASB backbones (as benchmarks.qsma)
RELATIVE = 1e-10  # omega and zeta of a converged level: GPU against CPU
ROM = Path("build/rom")
SEED = 40
BATCHES = (1, 10, 64, 256, 1024, 4096, 16384)  # designs per call of the batch timings


@functools.cache
def structure_space(structure: tuple[str, Path]):
    """The joint space of a structure (name, file): a beam's superelement (.npz of the reduction stage) or an ASB
    configuration's reduced model (.mat); once per process."""
    name, path = structure
    return joint_space(read_asb_superelement(path) if name.startswith("ASB ") else beam_superelement(path))


def available_structures(rom: Path = ROM, asb_models: Path = ASB_MODELS) -> list[tuple[str, Path]]:
    """(name, file) of the beams whose superelement is in ``rom``, and of the ASB's CD1 where its reduced model
    is in ``asb_models``."""
    structures = [(beam, rom / f"{beam}.npz") for beam in ("BRB", "LBRB", "SBRB") if (rom / f"{beam}.npz").exists()]
    cd1 = asb_models / "MAT_NULLRED_CD1.mat"
    return structures + ([("ASB CD1", cd1)] if cd1.exists() else [])


@contextlib.contextmanager
def timed_kernels(device: str):
    """The device's two kernels (``nonlinear.compute_devices``) wrapped, while in the block, to add their wall times
    (s) to the yielded dict's "stuck" and "levels"."""
    seconds = {"stuck": 0.0, "levels": 0.0}

    def timed(name, kernel):
        def call(*arguments):
            start = time.perf_counter()
            result = kernel(*arguments)
            seconds[name] += time.perf_counter() - start
            return result
        return call

    if device == "cpu":
        original = compute_devices.CPU
        compute_devices.CPU = compute_devices.Kernels(timed("stuck", original.stuck_designs),
                                                      timed("levels", original.solve_levels))
        try:
            yield seconds
        finally:
            compute_devices.CPU = original
        return
    from nonlinear import qsma_cuda

    original = qsma_cuda.stuck_designs, qsma_cuda.solve_levels
    qsma_cuda.stuck_designs, qsma_cuda.solve_levels = timed("stuck", original[0]), timed("levels", original[1])
    try:
        yield seconds
    finally:
        qsma_cuda.stuck_designs, qsma_cuda.solve_levels = original


def evaluate(structure: tuple[str, Path], model: str, designs: np.ndarray, amplitudes: np.ndarray,
             device: str) -> tuple:
    """QSMA of ``designs`` on ``device``: (frequency, damping, reason as str) each (n, L), the stuck frequency
    (n,), the seconds of the stuck-mode kernel, of the levels' kernel and of the whole call."""
    with timed_kernels(device) as seconds:
        start = time.perf_counter()
        result = qsma_vectorised.qsma_designs(structure_space(structure), model, designs, amplitudes=amplitudes,
                                              linear_damping=1e-3, device=device)
        total = time.perf_counter() - start
    return (result.frequency, result.damping, result.reason.astype(str), result.stuck_frequency, seconds["stuck"],
            seconds["levels"], total)


def n_groups(structure: tuple[str, Path]) -> int:
    """The structure's number of patch groups (a design's width)."""
    return max(structure_space(structure).superelement.patch_groups) + 1


def cpu_share(task: tuple) -> tuple:
    """``evaluate`` on the CPU of one process's share (a worker's task)."""
    return evaluate(*task, "cpu")


def compared(cpu: tuple, gpu: tuple) -> dict:
    """Per-level comparison: the largest relative difference of the stuck frequency, of omega and of zeta where
    both are defined, the designs whose stuck mode is defined on one device only, the levels whose reason
    differs, and the designs with one, split into branch differences at a flag (every earlier level equal within
    RELATIVE) and drifts, with the (cpu, gpu) reason pairs of the first differing level."""
    frequency = np.abs(gpu[0] / cpu[0] - 1.0)
    damping = np.abs(gpu[1] / cpu[1] - 1.0)
    stuck = np.abs(gpu[3] / cpu[3] - 1.0)
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
    return {"stuck_frequency": float(stuck[np.isfinite(stuck)].max(initial=0.0)),
            "stuck_defined_differ": int((np.isfinite(cpu[3]) != np.isfinite(gpu[3])).sum()),
            "omega": float(frequency[both].max(initial=0.0)), "zeta": float(damping[both].max(initial=0.0)),
            "levels": int(cpu[0].size), "reasons_differ": int((~same_reason).sum()),
            "flagged": int((cpu[2] != "").sum()), "branch_at_flag": flags, "drift": drifts, "pairs": dict(pairs)}


def measure(structure: tuple[str, Path], model: str, n_designs: int, amplitudes: np.ndarray, pool,
            workers: int) -> dict:
    """One structure and model: the GPU against the CPU kernels on the same designs; rates in designs per second
    (the CPU's: its processes' kernel seconds summed, over the number of processes)."""
    designs = random_designs(model, n_designs, n_groups(structure), np.random.default_rng(SEED))
    shares = np.array_split(designs, workers)
    start = time.perf_counter()
    parts = list(pool.map(cpu_share, [(structure, model, share, amplitudes) for share in shares]))
    cpu_wall = time.perf_counter() - start
    cpu = tuple(np.concatenate([part[k] for part in parts]) for k in range(4))
    cpu_stuck, cpu_levels = (sum(part[k] for part in parts) / workers for k in (4, 5))
    gpu = evaluate(structure, model, designs, amplitudes, "cuda")
    return {"structure": structure[0], "model": model, "designs": n_designs,
            "cpu_stuck_per_s": n_designs / cpu_stuck, "gpu_stuck_per_s": n_designs / gpu[4],
            "cpu_levels_per_s": n_designs / cpu_levels, "gpu_levels_per_s": n_designs / gpu[5],
            "cpu_per_s": n_designs / cpu_wall, "gpu_per_s": n_designs / gpu[6], **compared(cpu, gpu[:4])}


def batch_seconds(structure: tuple[str, Path], model: str, amplitudes: np.ndarray, sizes: Sequence[int] = BATCHES,
                  repeats: int = 3) -> list[dict]:
    """The wall time (s) of one ``qsma_designs`` call of each batch size of ``sizes`` on the GPU and on one CPU
    core (this process), the best of ``repeats``."""
    rows = []
    for size in sizes:
        designs = random_designs(model, size, n_groups(structure), np.random.default_rng(SEED))
        best = {device: min(evaluate(structure, model, designs, amplitudes, device)[6] for _ in range(repeats))
                for device in ("cpu", "cuda")}
        rows.append({"structure": structure[0], "model": model, "designs": size, "cpu_core_s": best["cpu"],
                     "gpu_s": best["cuda"]})
    return rows


def batch_table(rows: list[dict]) -> list[str]:
    """The markdown table of the batch timings."""
    return ["| structure | model | designs a call | one CPU core (ms) | GPU (ms) | speed-up on the GPU |",
            "|" + "---|" * 6,
            *(f"| {r['structure']} | {r['model']} | {r['designs']} | {1e3 * r['cpu_core_s']:.2f} | "
              f"{1e3 * r['gpu_s']:.2f} | {r['cpu_core_s'] / r['gpu_s']:.2f} |" for r in rows)]


def table(rows: list[dict], workers: int) -> list[str]:
    """The markdown table of the measurements."""
    lines = [f"| structure | model | designs | stuck modes/s CPU ({workers} proc.) | GPU | levels/s CPU | GPU | "
             "whole/s CPU | GPU | ratio | max rel stuck f | max rel omega | max rel zeta | stuck defined differ | "
             "reasons differ | at flag | drift |", "|" + "---|" * 17]
    for r in rows:
        lines.append(f"| {r['structure']} | {r['model']} | {r['designs']} | {r['cpu_stuck_per_s']:.0f} | "
                     f"{r['gpu_stuck_per_s']:.0f} | {r['cpu_levels_per_s']:.0f} | {r['gpu_levels_per_s']:.0f} | "
                     f"{r['cpu_per_s']:.0f} | {r['gpu_per_s']:.0f} | {r['gpu_per_s'] / r['cpu_per_s']:.2f} | "
                     f"{r['stuck_frequency']:.1e} | {r['omega']:.1e} | {r['zeta']:.1e} | "
                     f"{r['stuck_defined_differ']} | {r['reasons_differ']} of {r['levels']} | "
                     f"{r['branch_at_flag']} | {r['drift']} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="folder for gpu_qsma.json and gpu_qsma.md")
    parser.add_argument("--designs", type=int, default=10000)
    parser.add_argument("--levels", type=int, default=20)
    parser.add_argument("--structures", nargs="+", default=None, help="names (default: every one found)")
    parser.add_argument("--models", nargs="+", default=list(MODEL_NAMES), choices=MODEL_NAMES)
    parser.add_argument("--workers", type=int, default=os.cpu_count())
    parser.add_argument("--batches", type=int, nargs="+", default=BATCHES, help="designs a call, batch timings")
    parser.add_argument("--rom", type=Path, default=ROM, help="folder of the beams' superelements")
    parser.add_argument("--asb-models", type=Path, default=ASB_MODELS, help="folder of the ASB's reduced models")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    amplitudes = np.geomspace(*AMPLITUDE_RANGE, args.levels)
    structures = [structure for structure in available_structures(args.rom, args.asb_models)
                  if args.structures is None or structure[0] in args.structures]
    warm = random_designs(args.models[0], 2, n_groups(structures[0]), np.random.default_rng(0))
    rows = []
    # spawned workers: none inherits the GPU context of this process
    with ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(cpu_share, [(structures[0], args.models[0], warm, amplitudes)] * args.workers))
        start = time.perf_counter()
        evaluate(structures[0], args.models[0], warm, amplitudes, "cuda")  # numba-cuda compiles the kernel
        compile_seconds = time.perf_counter() - start
        print(f"GPU kernel compiled and run on 2 designs: {compile_seconds:.1f} s", flush=True)
        batches = batch_seconds(structures[0], args.models[0], amplitudes, args.batches)
        print("\n".join(batch_table(batches)), flush=True)
        for structure in structures:
            for model in args.models:
                rows.append(measure(structure, model, args.designs, amplitudes, pool, args.workers))
                print(table(rows[-1:], args.workers)[-1], flush=True)
    lines = [*table(rows, args.workers), "", *batch_table(batches)]
    print("\n".join(lines))
    (args.out / "gpu_qsma.md").write_text("\n".join(lines) + "\n")
    (args.out / "gpu_qsma.json").write_text(json.dumps(
        {"compile_seconds": compile_seconds, "levels": args.levels, "workers": args.workers,
         "relative": RELATIVE, "rows": rows, "batches": batches}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
