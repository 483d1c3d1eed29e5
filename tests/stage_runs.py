"""Helpers of the interruption and determinism tests: a stage run as a real ``surrogacy`` process, and the
digest of a stage's output folder that two runs are compared by."""

from __future__ import annotations

import hashlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

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
