"""numba's on-disk cache of the compiled kernels, kept consistent with their sources.

numba checks a cached kernel against the source file that defines it only (its modification time and size), but
the kernels inline functions of the other kernel files (``nonlinear.dense_linear_algebra`` into
``nonlinear.stuck_modes`` and ``nonlinear.qsma_kernel``, all three into the CUDA kernels of
``nonlinear.qsma_cuda``; the element laws of ``nonlinear.slip_laws``, ``nonlinear.iwan`` and
``nonlinear.parameters`` into the one-mode model of ``nonlinear.modal_joint``): after a change to one file alone
(an edit, a ``git pull``) the others would load compiled code of the old one. ``drop_stale_kernels`` keys the
cache on every kernel file at once: the SHA-256 of their sources and of the numba and Python versions is stamped
beside the cache, and where it differs every compiled file of those kernels is removed, so that they compile
afresh. It runs when the package is imported (``nonlinear/__init__.py``), before any kernel is called.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import sys
from pathlib import Path

import numba
from numba.core.caching import UserProvidedCacheLocator

KERNEL_MODULES = ("dense_linear_algebra", "stuck_modes", "qsma_kernel")
"""The CPU kernels' modules, which every QSMA call compiles at first use."""
CACHED_MODULES = (*KERNEL_MODULES, "qsma_cuda", "modal_joint", "slip_laws", "iwan", "parameters")
"""Every module whose compiled code numba keeps on disk: the QSMA CPU kernels and the CUDA ones built from them,
the one-mode model's kernel and the element laws it compiles."""
STAMP = "compiled-kernels.sha256"


def kernel_digest(folder: Path) -> str:
    """SHA-256 of the cached modules' sources in ``folder``, numba's version and Python's."""
    digest = hashlib.sha256(f"numba {numba.__version__} python {sys.version}".encode())
    for module in CACHED_MODULES:
        digest.update((folder / f"{module}.py").read_bytes())
    return digest.hexdigest()


def cache_folder(folder: Path) -> Path:
    """Where numba keeps the compiled code of the modules in ``folder``: its own subfolder of ``NUMBA_CACHE_DIR``
    where that is set (numba's ``UserProvidedCacheLocator``: the folder's name and a hash of its path), else
    ``folder/__pycache__``."""
    if numba.config.CACHE_DIR:
        return Path(numba.config.CACHE_DIR) / UserProvidedCacheLocator.get_suitable_cache_subpath(
            str(Path(folder) / "__init__.py"))
    return Path(folder) / "__pycache__"


def drop_stale_kernels(folder: Path = Path(__file__).parent) -> list[Path]:
    """Remove numba's cached index and data files (``.nbi``, ``.nbc``) of the cached modules in their
    ``cache_folder`` unless the stamp there holds the current ``kernel_digest``, then stamp it; returns the files
    removed. Nothing is done where neither ``NUMBA_CACHE_DIR`` is set nor the folder can be written (numba then
    caches elsewhere, and an installed package's files change all together)."""
    cache = cache_folder(folder)
    if not numba.config.CACHE_DIR and not os.access(folder, os.W_OK):
        return []
    current = kernel_digest(folder)
    stamp = cache / STAMP
    with contextlib.suppress(OSError):
        if stamp.read_text() == current:
            return []
    removed = [path for module in CACHED_MODULES for prefix in ("", "guf-") for kind in ("nbi", "nbc")
               for path in cache.glob(f"{prefix}{module}.*.{kind}")]  # guf-: numba's name for a gufunc's files
    for path in removed:
        with contextlib.suppress(FileNotFoundError):  # another process starting at once removed it first
            path.unlink()
    cache.mkdir(parents=True, exist_ok=True)
    temporary = cache / f".{STAMP}-{os.getpid()}"
    temporary.write_text(current)
    os.replace(temporary, stamp)
    return removed


def kernels_cached(folder: Path = Path(__file__).parent) -> bool:
    """Whether numba's on-disk cache (``cache_folder``) holds compiled code, an index file ``.nbi``, of every
    kernel module: where it does not, the first QSMA call compiles them (about half a minute and 0.5 GB on two
    cores, once)."""
    cache = cache_folder(folder)
    return cache.is_dir() and all(next(cache.glob(f"{module}.*.nbi"), None) is not None for module in KERNEL_MODULES)


@functools.cache
def announce_compiling() -> None:
    """Say once per process, on stderr, that the kernels are being compiled where ``kernels_cached`` finds them
    not cached (called before the first kernel call: a cold compile is half a minute without another word)."""
    if not kernels_cached():
        print("compiling the QSMA kernels, first use only (about half a minute on two cores; numba keeps them on "
              "disk) ...", file=sys.stderr, flush=True)
