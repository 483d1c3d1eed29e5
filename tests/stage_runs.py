"""Helpers of the interruption, determinism and compute-device tests: a stage run as a real ``surrogacy`` process,
the digest of a stage's output folder that two runs are compared by, and a run that counts which device's kernels
its evaluations called."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from locations import REPOSITORY
from pipeline.files import PARTIAL, sha256_file

SURROGACY = Path(sys.executable).with_name("surrogacy")  # the console script beside the venv's python
COARSE = ["--set", "mesh.size=0.0127", "--set", "mesh.lap_size=0.0064", "--set", "mesh.hole_size=0.0032"]


def start(arguments: list[str], log: Path) -> subprocess.Popen:
    """Start ``surrogacy <arguments>`` with its stderr (progress bars, messages) in ``log``.

    SIGINT is reset to its default action in the child before Python starts, as in a terminal: a test run in the
    background (SIGINT ignored, which every child would inherit) still sees what Ctrl-C does to a user."""
    with open(log, "w") as stream:
        return subprocess.Popen([str(SURROGACY), *arguments], stdout=subprocess.DEVNULL, stderr=stream,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def wait_for(condition, process: subprocess.Popen, what: str, timeout: float = 300.0) -> None:
    """Poll ``condition()`` every 10 ms until true; fail the test if ``process`` ends first or ``timeout`` s pass."""
    deadline = time.monotonic() + timeout
    while not condition():
        if process.poll() is not None:
            raise AssertionError(f"the run ended (status {process.returncode}) before {what}")
        if time.monotonic() > deadline:
            process.kill()
            raise AssertionError(f"no {what} within {timeout} s")
        time.sleep(0.01)


def partial_files(folder: Path) -> list[Path]:
    """The temporaries of ``pipeline.files.atomic_path`` anywhere below ``folder``."""
    return sorted(Path(folder).rglob(f"{PARTIAL}*"))


def digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every file below ``folder`` (hidden ones included) by relative path, and of every array of each
    .npz under ``<file>:<array>`` (over its dtype, shape and bytes), so that a difference names the array."""
    result = {}
    for path in sorted(p for p in Path(folder).rglob("*") if p.is_file()):
        name = str(path.relative_to(folder))
        result[name] = sha256_file(path)
        if path.suffix == ".npz":
            with np.load(path, allow_pickle=False) as arrays:
                for key in arrays.files:
                    array = arrays[key]
                    header = f"{array.dtype.str} {array.shape}".encode()
                    result[f"{name}:{key}"] = hashlib.sha256(header + np.ascontiguousarray(array).tobytes()).hexdigest()
    return result


def run_to_end(arguments: list[str], log: Path, timeout: float = 600.0) -> int:
    """Run ``surrogacy <arguments>`` uninterrupted (stderr in ``log``); its exit status."""
    return start(arguments, log).wait(timeout=timeout)


# ``surrogacy`` with its arguments (after the first, "simulated" or "cpu"), counting the calls of each compute
# device's kernels (``nonlinear.compute_devices``); with "cpu", the CUDA path's kernels are the CPU kernels they are
# compiled from (a command's plumbing to the device, at the CPU's speed; the simulator tests check the kernels).
COUNTED_DEVICES = """
import json
import sys
from cli.console import main
from nonlinear import compute_devices, qsma_cuda
stand_in = sys.argv.pop(1) == "cpu"
cpu, calls = compute_devices.CPU, {}
def counted(key, kernel):
    calls[key] = 0
    def call(*arguments):
        calls[key] += 1
        return kernel(*arguments)
    return call
for name in compute_devices.Kernels._fields:
    setattr(qsma_cuda, name, counted(f"cuda {name}", getattr(cpu if stand_in else qsma_cuda, name)))
compute_devices.CPU = compute_devices.Kernels(*(counted(f"cpu {name}", kernel)
                                                for name, kernel in cpu._asdict().items()))
status = main(sys.argv[1:])
print(json.dumps(calls))
sys.exit(status)
"""


def device_calls(arguments: list[str], cuda_kernels: str) -> dict[str, int]:
    """Run ``surrogacy <arguments>`` in numba-cuda's simulator (NUMBA_ENABLE_CUDASIM=1), with the CUDA
    path's kernels "simulated" (the simulator's) or "cpu" (the CPU kernels as stand-ins); returns the calls of each
    device's kernels ("cpu stuck_designs", "cuda solve_levels", ...). Fails the test where the run fails."""
    assert cuda_kernels in ("simulated", "cpu"), cuda_kernels
    run = subprocess.run([sys.executable, "-c", COUNTED_DEVICES, cuda_kernels, *arguments], cwd=REPOSITORY,
                         env={**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-4000:]
    return json.loads(run.stdout.splitlines()[-1])
