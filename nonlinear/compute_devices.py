"""The compute devices of the design evaluation: where the stuck modes and the QSMA levels of many designs are
solved (``nonlinear.qsma_vectorised.qsma_designs``, ``nonlinear.condensation.stuck_modes``).

    cpu    the numba CPU kernels: ``nonlinear.stuck_modes.stuck_designs``, ``nonlinear.qsma_kernel.solve_levels``
    cuda   the same Python source compiled for a CUDA GPU, one thread per design (``nonlinear.qsma_cuda``:
           numba-cuda, and a GPU or numba-cuda's simulator)

Both take and return numpy arrays; their results agree to round-off (``nonlinear.qsma_cuda`` says where a flag
decided at a threshold can differ).
"""

from __future__ import annotations

from typing import Callable, NamedTuple

from nonlinear import qsma_kernel, stuck_modes

DEVICES = ("cpu", "cuda")


class Kernels(NamedTuple):
    """A device's two kernels, with the arguments and results of the CPU ones."""

    stuck_designs: Callable
    solve_levels: Callable


CPU = Kernels(stuck_modes.stuck_designs, qsma_kernel.solve_levels)


def kernels(device: str) -> Kernels:
    """The kernels of ``device`` (one of DEVICES). ValueError for another name; RuntimeError naming what "cuda"
    lacks (numba-cuda, or a GPU)."""
    if device == "cpu":
        return CPU
    if device != "cuda":
        raise ValueError(f"device={device!r}: expected one of {DEVICES}")
    try:  # numba-cuda is an optional dependency, imported only where asked for
        from nonlinear import qsma_cuda
    except ImportError as error:
        raise RuntimeError(f"device='cuda': numba-cuda is not installed ({error}); install the project's `gpu` "
                           "extra (pip install -e '.[gpu]') or use device='cpu'") from None
    qsma_cuda.require_gpu()
    return Kernels(qsma_cuda.stuck_designs, qsma_cuda.solve_levels)


def check_device(device: str, setting: str) -> None:
    """ValueError naming ``setting`` (where the user chose the device) unless ``device``'s kernels can run in this
    process (``kernels``: numba-cuda and a GPU for "cuda"); for a command to check before it writes anything."""
    try:
        kernels(device)
    except RuntimeError as error:
        raise ValueError(f"{setting}: {error}") from None
