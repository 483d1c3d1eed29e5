"""The CUDA path's check on a GPU machine in one command, and the bundle it needs, prepared here without a GPU.

A GPU machine is lent rarely, for minutes, without network, with Python 3.12 and an image that has numpy, scipy,
numba, numba-cuda, pyarrow, pandas, statsmodels and tqdm but not the rest of the project's dependencies. So:

``python -m benchmarks.gpu_check prepare [BUNDLE]`` (here, ``make gpu-check-bundle``; default build/gpu-check, under
build/ and so ignored by git) writes what the check reads, in about 35 MiB:
    rom/<beam>.npz            the beams' superelements from build/rom without the stress-recovery arrays (the
                              designs' evaluation reads only the superelement: the same joint spaces, the same
                              study key)
    asb-reduced-models/       the ASB's reduced model of CD1 (from the measured data)
    study-beams/              the beams' study folder from results/study-beams: study.json and measurements/ (the
                              virtual experiments, not repeated there)
    wheels/                   the Python 3.12 wheels of what the image lacks for the study, and numpy and numba-cuda
                              at versions that compile CUDA together (``WHEELS``), installed there with --no-index

``python -m benchmarks.gpu_check run OUT [--bundle BUNDLE]`` (there, after ``pip install --no-index --no-deps
--target /tmp/site BUNDLE/wheels/*.whl`` and with PYTHONPATH=/tmp/site:.), each part written to OUT as it ends:
    1. ``benchmarks.gpu_qsma`` on the three beams and ASB CD1, every friction model, 10,000 designs at 20 levels:
       stuck modes and levels on the GPU against the CPU kernels on every core (equality within 1e-10 relative,
       flags counted; designs per second), and one call of 1 to 16,384 designs on the GPU against one core ->
       gpu_qsma.md, gpu_qsma.json;
    2. the beams' study at the paper's scale (5,000,000 designs per model, 4 models, 3 beams, 20 levels) by the
       study command's explore and analyse steps on a LocalCluster with compute.device=cuda, then the same steps
       with compute.device=cpu on the same cluster for ``--cpu-designs`` designs per model: wall time of each step,
       peak resident memory of the process tree and peak GPU memory (sampled), the exploration's designs per
       second; the chunks both runs share compared row by row (errors within 1e-10 relative, flags and reasons
       equal) -> gpu_check.json, gpu_check.md, the two runs' output in gpu_study.log and cpu_study.log;
    3. on the CPU study, where it finished, ``surrogacy confidence`` (Jenkins, the BRB as surrogate, half the
       paper's acceptance bounds, 2,000 designs per level, a LocalCluster) with --device cuda and with cpu: wall
       times, and the two tables compared as the chunks are -> gpu_check.json, gpu_check.md,
       confidence_cuda.log and confidence_cpu.log.
One command there (the device tool's run, OUT its $OUT)::

    python3 -m pip install -q --no-index --no-deps --target /tmp/site build/gpu-check/wheels/*.whl &&
    PYTHONPATH=/tmp/site:. PYTHONUNBUFFERED=1 python3 -m benchmarks.gpu_check run $OUT

With NUMBA_ENABLE_CUDASIM=1 and tiny sizes (``--designs 3 --levels 4 --batches 1 2 --study-designs 40 --cpu-designs
40 --chunk 20 --workers 2 --confidence-designs 20 --set pareto.generations=1 pareto.population=4``) the same run
goes through numba-cuda's simulator here.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from importlib import metadata
from pathlib import Path

import numba
import numpy as np
import pandas as pd
import psutil
import pyarrow.parquet as pq

from benchmarks import ASB_MODELS, gpu_qsma, study
from benchmarks.table import row
from nonlinear import compute_devices
from nonlinear.friction_models import MODEL_NAMES
from pipeline.runners import runner
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ
from study.exploration import Exploration, Sample, explore

ROM = Path("build/rom")
STUDY = Path("results/study-beams")
BUNDLE = Path("build/gpu-check")
BEAMS = ("BRB", "LBRB", "SBRB")
RECOVERY = ("interface_lower_recovery", "interface_upper_recovery", "vertex_recovery", "tetrahedra",
            "interface_points")
"""Arrays of a beam's reduction output that map the superelement back to the mesh (stresses, figures): not read
by the designs' evaluation, and most of the file."""
WHEELS = ("numpy", "numba-cuda", "scikit-fem", "dask", "distributed", "tornado", "zict", "tblib", "partd", "locket",
          "pymoo", "moocore", "cffi", "pycparser", "platformdirs", "autograd", "cma", "alive-progress", "about-time",
          "graphemeu", "deprecated")
"""What the GPU machine's image lacks for the study's explore and analyse steps (dask.distributed, pymoo,
scikit-fem and their own needs), and the two it has at versions that do not compile CUDA together: numba-cuda
0.30 registers ``np.row_stack``, which numpy 2.5 removed (seen here on Python 3.12 with numpy 2.5.5: numba-cuda's
CUDA target fails to load; the simulator does not load it). Each at its version in the environment that prepares
the bundle (the project's tested ones); installed ahead of the image's packages on the path."""
PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
             "manylinux1_x86_64")
RELATIVE = 1e-10


def prepare(bundle: Path) -> None:
    """Write the bundle (module docstring) from build/rom, results/study-beams and the measured data."""
    missing = [path for path in (*(ROM / f"{beam}.npz" for beam in BEAMS), STUDY / "study.json",
                                 STUDY / "measurements", ASB_MODELS / "MAT_NULLRED_CD1.mat") if not path.exists()]
    if missing:
        raise SystemExit(f"gpu_check prepare: {missing[0]} is missing (make rom, make study-beams; the measured data "
                         "in ../shared/data or data/)")
    if bundle.exists():
        shutil.rmtree(bundle)
    (bundle / "rom").mkdir(parents=True)
    for beam in BEAMS:
        with np.load(ROM / f"{beam}.npz", allow_pickle=False) as data:
            kept = {name: data[name] for name in data.files if name not in RECOVERY}
        np.savez(bundle / "rom" / f"{beam}.npz", **kept)
    (bundle / "asb-reduced-models").mkdir()
    shutil.copy2(ASB_MODELS / "MAT_NULLRED_CD1.mat", bundle / "asb-reduced-models")
    (bundle / "study-beams").mkdir()
    shutil.copy2(STUDY / "study.json", bundle / "study-beams")
    shutil.copytree(STUDY / "measurements", bundle / "study-beams" / "measurements")
    platforms = [option for platform in PLATFORMS for option in ("--platform", platform)]
    subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--only-binary=:all:",
                    "--python-version", "3.12", "--implementation", "cp", *platforms, "-d", str(bundle / "wheels"),
                    *(f"{name}=={metadata.version(name)}" for name in WHEELS)], check=True)
    size = sum(path.stat().st_size for path in bundle.rglob("*") if path.is_file())
    print(f"wrote {bundle}: {size / 2 ** 20:.1f} MiB")


def gpu_memory_reader():
    """A function giving the memory in use on the first GPU (MiB, by NVML), or None where nvidia-ml-py (on the GPU
    machine, not a dependency of the project) or a driver is missing."""
    try:
        import pynvml
    except ImportError:
        return None
    try:
        pynvml.nvmlInit()
        handle = pynvml.nvmlDeviceGetHandleByIndex(0)
    except pynvml.NVMLError:
        return None
    return lambda: pynvml.nvmlDeviceGetMemoryInfo(handle).used / 2 ** 20


class PeakSampler:
    """Peak resident memory (MiB) of this process and all its descendants, and peak GPU memory in use (MiB, NVML;
    None where nvidia-ml-py or a GPU is missing), sampled every ``interval`` s in a thread while in the block."""

    def __init__(self, interval: float = 0.5):
        self.interval, self.host_mib, self.gpu_mib = interval, 0.0, None
        self._stop = threading.Event()

    def _sample(self) -> None:
        gpu_used, root = gpu_memory_reader(), psutil.Process()
        while not self._stop.is_set():
            total = 0
            for process in (root, *root.children(recursive=True)):
                try:
                    total += process.memory_info().rss
                except psutil.Error:  # ended between the listing and the reading
                    pass
            self.host_mib = max(self.host_mib, total / 2 ** 20)
            if gpu_used is not None:
                self.gpu_mib = max(self.gpu_mib or 0.0, gpu_used())
            self._stop.wait(self.interval)

    def __enter__(self):
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exception):
        self._stop.set()
        self._thread.join()


STUDY_COMMAND = """
import argparse, sys
from study import commands
parser = argparse.ArgumentParser(prog="surrogacy")
commands.register(parser.add_subparsers(dest="command"))
arguments = parser.parse_args(sys.argv[1:])
arguments.run(arguments)
"""
"""The study and confidence commands' own parser and run (``study.commands``), without the other stages' imports
(gmsh, PyVista, pyuff, pooch: not on the GPU machine)."""


def timed_command(command: list[str], log: Path, timeout: float | None) -> tuple:
    """Run ``command``, its output in ``log``, killed with its process group (a LocalCluster's processes) after
    ``timeout`` s: (exit status or "timed out", wall time s, its ``PeakSampler``)."""
    start = time.perf_counter()
    with PeakSampler() as peak, open(log, "w") as output:
        process = subprocess.Popen(command, stdout=output, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            status = process.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            status = "timed out"
    return status, time.perf_counter() - start, peak


def study_run(bundle: Path, folder: Path, device: str, designs: int, chunk: int, log: Path,
              settings: tuple = (), timeout: float | None = None) -> dict:
    """The explore and analyse steps of the beams' study into ``folder`` (its study.json and measurements copied
    from the bundle) on a LocalCluster (a worker per core), with ``device`` and further ``settings``
    (SECTION.FIELD=VALUE), stopped after ``timeout`` s (status "timed out"): wall time, peak host and GPU memory,
    the command's output in ``log``."""
    if folder.exists():
        shutil.rmtree(folder)
    shutil.copytree(bundle / "study-beams", folder)
    command = [sys.executable, "-c", STUDY_COMMAND, "study", "--out", str(folder), "--rom", str(bundle / "rom"),
               "--steps", "explore", "analyse", "--scheduler", "local", "--set", f"compute.device={device}",
               "--set", f"sample.n_designs={designs}", "--set", f"sample.chunk_size={chunk}",
               *(option for setting in settings for option in ("--set", setting))]
    status, seconds, peak = timed_command(command, log, timeout)
    manifest = folder / "designs" / "exploration.json"
    models = json.loads(manifest.read_text())["models"] if manifest.exists() else []
    explored = re.search(r"explored \d+ chunk\(s\) .* in (\d+) s", log.read_text())
    explore_seconds = float(explored.group(1)) if explored else None
    evaluations = designs * len(models) * len(BEAMS)
    return {"device": device, "designs_per_model": designs, "chunk": chunk, "status": status,
            "seconds": seconds, "explore_seconds": explore_seconds,
            "explore_evaluations_per_s": evaluations / explore_seconds if explore_seconds else None,
            "peak_host_mib": peak.host_mib, "peak_gpu_mib": peak.gpu_mib}


def compared_columns(expected, found, where: str) -> tuple[float, list[str]]:
    """Two tables (pandas DataFrames of the same columns) column by column: the largest relative difference of the
    float columns from the CPU's ``expected`` (NaN where it is NaN), and the columns, named with ``where``, whose
    NaNs or other values differ."""
    worst, differing = 0.0, []
    for name in expected.columns:
        if expected[name].dtype.kind == "f":
            a, b = expected[name].to_numpy(), found[name].to_numpy(dtype=float)
            if not np.array_equal(np.isnan(a), np.isnan(b)):
                differing.append(f"{where}: {name} NaN elsewhere")
                continue
            scale = np.abs(a)
            relative = np.abs(b - a)[scale > 0] / scale[scale > 0]
            worst = max(worst, float(relative.max(initial=0.0)))
        elif expected[name].astype(str).tolist() != found[name].astype(str).tolist():
            differing.append(f"{where}: {name}")
    return worst, differing


def shared_chunks(gpu: Path, cpu: Path) -> dict:
    """The chunk files both studies wrote (the same designs: a chunk's designs depend on its seed and index only),
    compared column by column (``compared_columns``)."""
    worst, differing, files = 0.0, [], 0
    for path in sorted((cpu / "designs").glob("*/chunk-*.parquet")):
        other = gpu / "designs" / path.parent.name / path.name
        if not other.exists():
            continue
        files += 1
        chunk_worst, chunk_differing = compared_columns(pq.read_table(path).to_pandas(),
                                                        pq.read_table(other).to_pandas(), str(other))
        worst, differing = max(worst, chunk_worst), differing + chunk_differing
    return {"files": files, "max_relative": worst, "within": worst <= RELATIVE, "differing": differing[:20],
            "n_differing": len(differing)}


def confidence_runs(study: Path, designs: int, out: Path, scratch: Path, timeout: float | None) -> dict:
    """``surrogacy confidence`` of Jenkins with the BRB as surrogate on the finished ``study``, at half the paper's
    acceptance bounds, on a LocalCluster (a worker per core), ``designs`` per level and in the acceptance region,
    no restarts, with --device cuda and then cpu: each one's wall time and status (its output in
    OUT/confidence_<device>.log), the two tables compared (``compared_columns``) and the CPU table's rows with an
    estimate (none where the region was not reached)."""
    runs, tables = [], {}
    for device in ("cuda", "cpu"):
        table = scratch / f"confidence-{device}.csv"
        shutil.rmtree(table.with_name(table.name + ".levels"), ignore_errors=True)  # a run's state is resumed
        command = [sys.executable, "-c", STUDY_COMMAND, "confidence", "--study", str(study), "--model", "jenkins",
                   "--surrogate", "BRB", "--frequency-bound", str(FREQUENCY_TOLERANCE_HZ / 2),
                   "--damping-bound", str(DAMPING_TOLERANCE / 2), "--per-level", str(designs), "--conditional",
                   str(designs), "--restarts", "0", "--scheduler", "local", "--device", device, "--out", str(table)]
        status, seconds, _ = timed_command(command, out / f"confidence_{device}.log", timeout)
        runs.append({"device": device, "status": status, "seconds": seconds})
        tables[device] = pd.read_csv(table) if status == 0 else None
    if tables["cuda"] is None or tables["cpu"] is None:
        return {"runs": runs, "max_relative": None, "differing": []}
    worst, differing = compared_columns(tables["cpu"], tables["cuda"], "confidence table")
    return {"runs": runs, "max_relative": worst, "within": worst <= RELATIVE, "differing": differing,
            "estimated": int(tables["cpu"]["confidence"].notna().sum())}


def run(out: Path, bundle: Path, designs: int, levels: int, study_designs: int, cpu_designs: int, chunk: int,
        workers: int | None, settings: tuple = (), timeout: float | None = None,
        batches: Sequence[int] = gpu_qsma.BATCHES, confidence_designs: int = 2000) -> None:
    """The check (module docstring), each part written to ``out`` as it ends."""
    out.mkdir(parents=True, exist_ok=True)
    record = {"python": sys.version, "cores": os.cpu_count(), "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    smi = shutil.which("nvidia-smi")
    if smi:
        record["gpu"] = subprocess.run([smi, "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
                                       capture_output=True, text=True).stdout.strip()

    def write():
        (out / "gpu_check.json").write_text(json.dumps(record, indent=1))

    write()
    worker_options = ["--workers", str(workers)] if workers else []
    gpu_qsma.main([str(out), "--designs", str(designs), "--levels", str(levels), "--rom", str(bundle / "rom"),
                   "--asb-models", str(bundle / "asb-reduced-models"), "--batches", *map(str, batches),
                   *worker_options])
    scratch = Path(os.environ.get("TMPDIR", "/tmp")) / "gpu-check"
    record["studies"] = []
    for device, n in (("cuda", study_designs), ("cpu", cpu_designs)):
        record["studies"].append(study_run(bundle, scratch / device, device, n, chunk,
                                           out / f"{'gpu' if device == 'cuda' else 'cpu'}_study.log", settings,
                                           timeout))
        write()
    record["shared_chunks"] = shared_chunks(scratch / "cuda", scratch / "cpu")
    write()
    if record["studies"][-1]["status"] == 0:  # the CPU study, explored and analysed
        record["confidence"] = confidence_runs(scratch / "cpu", confidence_designs, out, scratch, timeout)
    record["ended"] = time.strftime("%Y-%m-%d %H:%M:%S")
    write()
    lines = ["| device | designs per model | chunk | status | explore and analyse (s) | explore (s) | "
             "explore evaluations/s | peak host (MiB) | peak GPU (MiB) |", "|---|---|---|---|---|---|---|---|---|"]
    for study in record["studies"]:
        rate, gpu_memory = study["explore_evaluations_per_s"], study["peak_gpu_mib"]
        lines.append(f"| {study['device']} | {study['designs_per_model']:,} | {study['chunk']:,} | {study['status']} | "
                     f"{study['seconds']:.0f} | {study['explore_seconds'] or '-'} | "
                     f"{f'{rate:,.0f}' if rate else '-'} | "
                     f"{study['peak_host_mib']:.0f} | {f'{gpu_memory:.0f}' if gpu_memory is not None else '-'} |")
    shared = record["shared_chunks"]
    lines.append(f"\nShared chunks: {shared['files']} files, largest relative difference {shared['max_relative']:.1e}, "
                 f"{shared['n_differing']} columns differing in flags or NaNs.")
    confidence = record.get("confidence")
    if confidence is None:
        lines.append("\nConfidence: not run (the CPU study did not finish).")
    else:
        worst = confidence["max_relative"]
        lines.append("\nConfidence (jenkins, BRB as surrogate, subset simulation on a LocalCluster): "
                     + ", ".join(f"{run['device']} {run['seconds']:.0f} s (status {run['status']})"
                                 for run in confidence["runs"])
                     + (f"; tables: {confidence['estimated']} rows estimated, largest relative difference "
                        f"{worst:.1e}, {len(confidence['differing'])} columns differing otherwise."
                        if worst is not None else "."))
    (out / "gpu_check.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def gpu_missing() -> str | None:
    """Why the GPU rows cannot run here (no numba-cuda, no GPU, or its simulator on), or None."""
    if numba.config.ENABLE_CUDASIM:
        return "numba-cuda's simulator is on (NUMBA_ENABLE_CUDASIM): no GPU timings"
    try:
        compute_devices.kernels("cuda")
    except RuntimeError as error:
        return str(error).split(";")[0]
    return None


def exploration_seconds(device: str, designs: int, chunk: int) -> tuple:
    """The paper's four models explored on the three beams (``benchmarks.study``'s known-answer structures), a
    LocalCluster of a worker per core, ``device``: (wall s, peak host MiB, peak GPU MiB or None)."""
    exploration = Exploration(study.beams(), study.PAPER_MODELS, Sample(seed=1, n_designs=designs, chunk_size=chunk),
                              study.DAMPING_CASES, device=device)
    with tempfile.TemporaryDirectory() as folder, PeakSampler() as peak, runner("local") as cluster:
        start = time.perf_counter()
        explore(exploration, Path(folder), cluster, progress=False)
        seconds = time.perf_counter() - start
    return seconds, peak.host_mib, peak.gpu_mib


def rows(designs: int = 20_000, explored: int = 1_000_000, chunk: int = 50_000):
    """``make bench``'s GPU rows, where a GPU is (else one row saying why not): per friction model on the BRB,
    ``designs`` designs at 20 levels on the GPU against the CPU kernels on every core, in one run
    (``benchmarks.gpu_qsma.measure``); then the paper's four models explored on the three beams, ``explored``
    designs per model in chunks of ``chunk`` on a LocalCluster, on the GPU and (a fifth of them) on the CPU: wall
    time, peak host and GPU memory, and the paper's scale (5,000,000 designs per model) projected from each."""
    missing = gpu_missing()
    if missing:
        yield row("gpu", "all rows", note=f"skipped: {missing}")
        return
    brb = next((structure for structure in gpu_qsma.available_structures() if structure[0] == "BRB"), None)
    if brb is None:
        yield row("gpu", "all rows", note=f"skipped: {ROM} lacks the BRB's superelement (run `make rom`)")
        return
    cores, amplitudes = os.cpu_count(), np.geomspace(*gpu_qsma.AMPLITUDE_RANGE, 20)
    with ProcessPoolExecutor(cores, mp_context=multiprocessing.get_context("spawn")) as pool:
        for model in MODEL_NAMES:
            measured = gpu_qsma.measure(brb, model, designs, amplitudes, pool, cores)
            yield row("gpu", f"{model}, BRB", rate=measured["gpu_per_s"] / measured["cpu_per_s"],
                      unit=f"x {cores} cores",
                      note=f"{designs:,} designs x 20 levels: GPU {measured['gpu_per_s']:,.0f} designs/s, CPU "
                           f"kernels on {cores} cores {measured['cpu_per_s']:,.0f}; largest relative difference "
                           f"omega {measured['omega']:.1e}, zeta {measured['zeta']:.1e}; reasons differ at "
                           f"{measured['reasons_differ']} of {measured['levels']} levels")
    paper = 5_000_000
    for device, n in (("cuda", explored), ("cpu", max(chunk, explored // 5))):
        seconds, host, gpu = exploration_seconds(device, n, chunk)
        evaluations = n * 4 * 3
        yield row("gpu", f"exploration, {device}", seconds, host, evaluations / seconds, "evaluations/s",
                  f"{n:,} designs x 4 models x 3 beams x 20 levels, chunks of {chunk:,}, LocalCluster of {cores}; "
                  f"peak GPU memory {f'{gpu:,.0f} MiB' if gpu is not None else 'not measured'}; the paper's scale "
                  f"projected: {seconds * paper / n:,.0f} s")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    making = commands.add_parser("prepare", help="write the bundle (here, without a GPU)")
    making.add_argument("bundle", type=Path, nargs="?", default=BUNDLE)
    checking = commands.add_parser("run", help="the check (on the GPU machine)")
    checking.add_argument("out", type=Path)
    checking.add_argument("--bundle", type=Path, default=BUNDLE)
    checking.add_argument("--designs", type=int, default=10_000, help="designs per model and structure, equality")
    checking.add_argument("--levels", type=int, default=20)
    checking.add_argument("--study-designs", type=int, default=5_000_000, help="designs per model, GPU study")
    checking.add_argument("--cpu-designs", type=int, default=1_000_000, help="designs per model, CPU study")
    checking.add_argument("--chunk", type=int, default=50_000, help="designs per chunk, both studies")
    checking.add_argument("--workers", type=int, default=None, help="CPU processes of the equality check (every core)")
    checking.add_argument("--study-timeout", type=float, default=240.0, help="seconds each study may take")
    checking.add_argument("--batches", type=int, nargs="+", default=gpu_qsma.BATCHES,
                          help="designs a call of the batch timings")
    checking.add_argument("--confidence-designs", type=int, default=2000,
                          help="designs per level and in the acceptance region, confidence runs")
    checking.add_argument("--set", dest="settings", nargs="*", default=(), metavar="SECTION.FIELD=VALUE",
                          help="further settings of both studies")
    arguments = parser.parse_args(argv)
    if arguments.command == "prepare":
        prepare(arguments.bundle)
    else:
        run(arguments.out, arguments.bundle, arguments.designs, arguments.levels, arguments.study_designs,
            arguments.cpu_designs, arguments.chunk, arguments.workers, tuple(arguments.settings),
            arguments.study_timeout, arguments.batches, arguments.confidence_designs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
