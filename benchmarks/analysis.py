"""Benchmark of the study's analysis pass: wall time and peak memory against the number of designs.

Run as ``python -m benchmarks.analysis [--designs N]``. A synthetic exploration folder (``synthetic_exploration``:
chunks with the exploration's schema, errors drawn at random; labelled synthetic, no QSMA run) of N and 4 N designs
of one model on three structures with three linear damping cases, chunks of 5,000 as at the paper's scale, is
analysed in a fresh process each: the streamed pass of the analyse step (``study.analysis.sample_counts``: counts
at the bounds, the 8 x 8 bounds sweep, replicate counts of every damping case, the fronts) and, beside it, the
whole error arrays in memory (``study.analysis.model_errors``), which the analysis held before it streamed. The
streamed pass's peak memory stays flat from N to 4 N; the in-memory one grows with N. Then the paper's scale
(5,000,000 designs per model, 4 models) projected from the streamed rate, beside the analysis and report measured
there when the analysis held the whole arrays (``MEASURED_IN_MEMORY``; not repeated by the benchmark).
"""

from __future__ import annotations

import argparse
import resource
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa

from benchmarks.peak import measure
from benchmarks.table import row, show
from nonlinear.joint import parameter_names
from pipeline.files import write_json
from study.analysis import model_errors, sample_counts
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ
from study.exploration import chunk_path, write_chunk

MODEL = "iwan4"
STRUCTURES = ("BRB", "LBRB", "SBRB")
CASES = ("BRB", "LBRB", "SBRB")
CHUNK = 5000
REPLICATES = 10
SWEEP = np.array([0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0])  # bounds over the acceptance bounds, as the study's
PAPER_DESIGNS = 5_000_000  # per model (paper section 4.3)
PAPER_MODELS = 4
MEASURED_IN_MEMORY = row(
    "analysis", "paper scale, in memory, 2026-11-23", 8 * 60 + 55,
    note="NOT measured by this run: analysis and report of `make study-full` when the analysis held each model's "
         "whole error arrays (5,000,000 designs per model, 4 models, 3 beams, this 2-core machine): 8 min 55 s, "
         "peak 6.1 GB")


def synthetic_chunk(model: str, chunk: int, length: int, chunk_size: int, structures, cases, n_replicates: int,
                    seed: int, resolution: float | None = None) -> pa.Table:
    """One chunk's rows with the exploration's columns (``study.exploration`` docstring), errors drawn at
    random: log-normal L-infinity errors about the acceptance bounds, each error correlated between the structures
    (a design good on one is likelier good on another), 5 % not converged (NaN errors, a reason). resolution: errors
    rounded to this many decades' fraction (e.g. 0.05), so that equal errors and equal designs occur."""
    rng = np.random.default_rng([seed, chunk])
    first = chunk * chunk_size
    common = {"frequency": rng.normal(size=length), "damping": rng.normal(size=length)}
    columns = {"model": pa.array([model] * length).dictionary_encode(),
               "design": np.arange(first, first + length, dtype=np.int64),
               "chunk": np.full(length, chunk, dtype=np.int32),
               "replicate": np.full(length, chunk % n_replicates, dtype=np.int16),
               "seed": np.full(length, seed, dtype=np.int64)}
    columns.update((name, rng.uniform(size=length)) for name in parameter_names(model, 3))

    def errors(kind, scale):
        exponent = np.log10(scale) + 0.8 * common[kind] + 0.6 * rng.normal(size=length)
        return 10.0 ** (np.round(exponent / resolution) * resolution if resolution else exponent)

    for name in structures:
        failed = rng.uniform(size=length) < 0.05
        columns[f"frequency_error_hz[{name}]"] = np.where(failed, np.nan,
                                                          errors("frequency", 4 * FREQUENCY_TOLERANCE_HZ))
        columns.update({f"damping_error[{name}][{case}]": np.where(failed, np.nan,
                                                                   errors("damping", 4 * DAMPING_TOLERANCE))
                        for case in cases})
        columns[f"converged[{name}]"] = ~failed
        reason = np.where(failed, np.where(rng.uniform(size=length) < 0.7, "no equilibrium", "reversed element"), "")
        columns[f"reason[{name}]"] = pa.array(reason.tolist()).dictionary_encode()
        columns[f"stuck_frequency_hz[{name}]"] = rng.uniform(150.0, 200.0, length)
    return pa.table(columns)


def synthetic_exploration(folder: Path, model: str, n_designs: int, chunk_size: int = CHUNK, structures=STRUCTURES,
                          cases=CASES, n_replicates: int = REPLICATES, seed: int = 0,
                          resolution: float | None = None) -> Path:
    """Write a synthetic exploration of ``model`` into ``folder`` (``synthetic_chunk`` per chunk, its manifest
    exploration.json with the sample, labelled synthetic); returns the folder."""
    folder = Path(folder)
    for chunk in range(-(-n_designs // chunk_size)):
        length = min(chunk_size, n_designs - chunk * chunk_size)
        write_chunk(synthetic_chunk(model, chunk, length, chunk_size, structures, cases, n_replicates, seed,
                                    resolution), chunk_path(folder, model, chunk), "synthetic")
    write_json(folder / "exploration.json", {
        "study_key": "synthetic", "provenance": "synthetic errors drawn at random (benchmarks.analysis)",
        "sample": {"seed": seed, "n_designs": n_designs, "chunk_size": chunk_size, "n_replicates": n_replicates},
        "models": [model], "structures": [{"name": name} for name in structures],
        "damping_cases": {case: [0.0] * len(structures) for case in cases}})
    return folder


def _peak_mib() -> float:
    """Peak resident memory of this process so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def streamed(folder: Path) -> tuple[int, float]:
    """The analyse step's pass over one model's chunks; returns the designs read and the peak memory (MiB) before
    the pass (the modules imported)."""
    before = _peak_mib()
    counts = sample_counts(folder, MODEL, list(STRUCTURES), CASES, CASES[0], FREQUENCY_TOLERANCE_HZ,
                           DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ * SWEEP, DAMPING_TOLERANCE * SWEEP,
                           progress=False)
    return counts.n_designs, before


def in_memory(folder: Path) -> tuple[int, float]:
    """One model's whole error arrays of each damping case, as the analysis held them before it streamed; returns
    the designs read and the peak memory (MiB) before."""
    before = _peak_mib()
    errors = [model_errors(folder, MODEL, list(STRUCTURES), case) for case in CASES]
    return len(errors[0].design), before


def rows(n_designs: int = 100_000) -> Iterator[dict]:
    """The rows of the module docstring."""
    rate = None
    with tempfile.TemporaryDirectory() as temporary:
        for size in (n_designs, 4 * n_designs):
            folder = synthetic_exploration(Path(temporary) / f"n{size}", MODEL, size)
            seconds, peak, (read, imported) = measure(streamed, folder)
            assert read == size
            rate = size / seconds
            yield row("analysis", f"streamed, {size:,} designs", seconds, peak, rate, "designs/s",
                      f"{peak - imported:.0f} MiB above the imported modules; synthetic errors, 1 model x "
                      f"{len(STRUCTURES)} structures x {len(CASES)} damping cases, chunks of {CHUNK:,}: counts, "
                      f"8 x 8 bounds sweep, replicates, fronts; wall time, fresh process")
            seconds, peak, (read, imported) = measure(in_memory, folder)
            assert read == size
            yield row("analysis", f"in memory, {size:,} designs", seconds, peak, size / seconds, "designs/s",
                      f"{peak - imported:.0f} MiB above the imported modules; the same folder's whole error arrays "
                      f"of each damping case held at once (model_errors), nothing counted")
    projected = PAPER_DESIGNS * PAPER_MODELS / rate
    yield row("analysis", "paper scale, streamed, projected", projected,
              note=f"{projected / 60:.1f} min: {PAPER_DESIGNS:,} designs x {PAPER_MODELS} models at the streamed "
                   f"rate above; memory as the streamed rows (flat in the number of designs)")
    yield MEASURED_IN_MEMORY


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=100_000, help="N: designs of the smaller folder")
    arguments = parser.parse_args(argv)
    show(rows(arguments.designs))


if __name__ == "__main__":
    main()
