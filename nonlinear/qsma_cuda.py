"""Stuck modes and QSMA levels on a CUDA GPU, one thread per design: ``nonlinear.stuck_modes`` and
``nonlinear.qsma_kernel`` compiled for numba-cuda from the same Python source as for the CPU.

``device_functions`` takes every numba CPU function defined in a kernel module and compiles its Python function,
unchanged, as a CUDA device function whose globals are a copy of the module's in which every such function is
its device version, so that the helpers call one another's CUDA builds. Two primitives are the target's own
(``TARGET_PRIMITIVES``): the power 2^(exponent log2 base) of ``qsma_kernel._power``, by ``math.exp2`` and
``math.log2`` (numba-cuda has no ``np.exp2``), and the eigen-decomposition of an ill-conditioned compliance in
``qsma_kernel.pseudo_inverse`` (LAPACK's on the CPU), by the Jacobi rotations of
``nonlinear.dense_linear_algebra`` (no LAPACK on the device). ``solve_levels`` takes the arguments of
``qsma_kernel.solve_levels`` and returns what it returns: each thread runs ``qsma_kernel.solve_design`` for its
design on its own work arrays, slices of global arrays with the design on the last axis (neighbouring threads
read neighbouring addresses); ``stuck_designs`` likewise for ``stuck_modes.stuck_designs`` (each thread
``stuck_modes.stuck_design``; the designs' shared flexibility at rest formed once on the CPU).

The numbers are the CPU kernel's to round-off, not to the bit: libdevice's exp2, log2 and pow are not the CPU's,
NVVM fuses multiply-adds (its default) and the Jacobi eigenvectors are not LAPACK's; a level decided at a
threshold (a flag, a substep's regime) can go either way where the two round-offs straddle it.
The two kernels are kept in numba's on-disk cache (a study's workers and the process that analyses it load them
instead of compiling them, about a minute each), which ``nonlinear.compiled_cache`` keys on every kernel source.
With NUMBA_ENABLE_CUDASIM=1 the same source runs in numba-cuda's simulator (interpreted Python on the CPU, for
tests without a GPU). Needs the package numba-cuda (the project's ``test`` and ``gpu`` extras).
"""

from __future__ import annotations

import functools
import math
import types

import numpy as np
import numba_cuda  # noqa: F401 (the CUDA target package; numba's own numba.cuda is deprecated)
from numba import cuda
from numba.core.registry import CPUDispatcher

from nonlinear import dense_linear_algebra, qsma_kernel, stuck_modes
from nonlinear.qsma_kernel import N_LAW, N_WORK_ROWS
from nonlinear.stuck_modes import HIGH_VECTORS, JOINT_VECTORS, LOW_MATRICES, LOW_VECTORS, SERIES_TERMS
from pipeline.runners import worker_name

THREADS_PER_BLOCK = 64
LEVEL_INPUTS, STUCK_INPUTS = 18, 13  # the kernels' arguments before their outputs (the levels' first: x)
SETTING = "device='cuda' (nonlinear.qsma_vectorised.qsma_designs)"


def device_functions(module: types.ModuleType, provided: dict) -> dict:
    """The globals of ``module`` with every numba CPU function defined there replaced by a CUDA device function
    compiled (at its first call) from the same Python function; ``provided``: device functions standing for the
    module's own of those names and for those it imports from other kernel modules (a KeyError names one
    missing)."""
    namespace = dict(vars(module))
    for name, value in vars(module).items():
        if not isinstance(value, CPUDispatcher):
            continue
        function = value.py_func
        if name in provided or function.__module__ != module.__name__:
            namespace[name] = provided[name]
            continue
        namespace[name] = cuda.jit(device=True)(types.FunctionType(
            function.__code__, namespace, function.__name__, function.__defaults__, function.__closure__))
    return namespace


DENSE = device_functions(dense_linear_algebra, {})


@cuda.jit(device=True)
def power(base, exponent):
    """``qsma_kernel._power`` on the device: base^exponent = 2^(exponent log2 base) by libdevice's exp2, log2."""
    return math.exp2(exponent * math.log2(base))


@cuda.jit(device=True)
def eigen_decomposition(matrix, values, vectors, scratch):
    """``qsma_kernel.eigen_decomposition`` on the device: cyclic Jacobi rotations
    (``dense_linear_algebra.symmetric_eigen_in_place``) on a copy of matrix (n, n) in scratch (n, n)."""
    symmetric_eigen_in_place(copy_matrix(matrix, scratch), values, vectors)


symmetric_eigen_in_place, copy_matrix = DENSE["symmetric_eigen_in_place"], DENSE["copy_matrix"]
TARGET_PRIMITIVES = {"_power": power, "eigen_decomposition": eigen_decomposition}
KERNEL = device_functions(qsma_kernel, {**TARGET_PRIMITIVES, **{
    name: DENSE[name] for name in ("ldl_back_substitute", "ldl_eliminate", "solve_dense")}})
solve_design = KERNEL["solve_design"]
STUCK = device_functions(stuck_modes, {name: DENSE[name] for name in (
    "backward_substitute", "cholesky", "copy_matrix", "dot", "forward_substitute", "matvec", "rmatvec", "solve_dense",
    "symmetric_eigen_in_place", "symmetric_solve")})
stuck_design, stuck_design_workspace = STUCK["stuck_design"], STUCK["design_workspace"]


@cuda.jit(cache=True)
def stuck_kernel(joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility,
                 reference_low, reference_high, unambiguous_mac, rows, static_packed, static_square, inverse_square,
                 eigenvalue, shape_low, shape_high, joint_shape, mac, compliance, found, low_estimates, joint_vectors,
                 low_vectors, high_vectors, low_matrices, packed, augmented, static_augmented, z, high_projection,
                 low_share, coefficients):
    """Thread d forms design d's stuck mode and compliance (``stuck_modes.stuck_design``) with the slices [..., d]
    of the work arrays (``stuck_workspace``)."""
    d = cuda.grid(1)
    if d < joint_stiffness.shape[0]:
        stuck_design(d, d + 1,
                     (joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility,
                      reference_low, reference_high, unambiguous_mac, rows, static_packed, static_square,
                      inverse_square),
                     (eigenvalue, shape_low, shape_high, joint_shape, mac, compliance, found, low_estimates),
                     stuck_design_workspace(joint_vectors[:, :, d], low_vectors[:, :, d], high_vectors[:, :, d],
                                            low_matrices[:, :, :, d], packed[:, d], augmented[:, :, d],
                                            static_augmented[:, :, d], z[:, :, d], high_projection[:, :, d],
                                            low_share[:, :, d], coefficients[:, d]))


@cuda.jit(cache=True)
def levels_kernel(levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                  amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined, solutions,
                  joint_displacement, slip_ratio, status, amplitude, force, frequency, damping, work, matrix,
                  compliance_pinv, waypoint, stuck_state, dropping, design_compliance, table, stiffness_scaled,
                  core_scaled, active):
    """Thread d solves design d (``qsma_kernel.solve_design``) with the slices [..., d] of the work arrays
    (``level_workspace``), its stuck state zeroed first."""
    d = cuda.grid(1)
    if d < defined.size and defined[d]:
        for i in range(stuck_state.shape[0]):
            stuck_state[i, d] = 0.0
        solve_design(d, (levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                         amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load),
                     (solutions, joint_displacement, slip_ratio, status, amplitude, force, frequency, damping),
                     (work[:, :, d], matrix[:, :, d], compliance_pinv[:, :, d], waypoint[:, d], stuck_state[:, d],
                      dropping[:, d], design_compliance[:, :, d], table[:, :, d], stiffness_scaled[:, d],
                      core_scaled[:, d], active[:, d]))


def level_workspace(n_designs: int, m: int) -> list:
    """(shape, dtype) of ``qsma_kernel.solve_design``'s work arrays for every design, the design on the last axis
    (``levels_kernel`` zeroes its design's stuck state; the rest starts uninitialised)."""
    return [((N_WORK_ROWS, m, n_designs), np.float64), ((m, 2 * m, n_designs), np.float64),
            ((m, m, n_designs), np.float64), ((m, n_designs), np.float64), ((m, n_designs), np.float64),
            ((m, n_designs), np.bool_), ((m, m, n_designs), np.float64), ((m, N_LAW, n_designs), np.float64),
            ((m, n_designs), np.float64), ((m, n_designs), np.float64), ((m, n_designs), np.int64)]


def stuck_workspace(n_designs: int, m: int, n_low: int, n_high: int, n_rows: int) -> list:
    """(shape, dtype) of ``stuck_modes.design_workspace``'s stacked arrays for every design, the design on the
    last axis (uninitialised)."""
    shapes = ((JOINT_VECTORS, m), (LOW_VECTORS, n_low), (HIGH_VECTORS, n_high), (LOW_MATRICES, n_low, n_low),
              (m * (m + 1) // 2,), (m, m + n_low + 1), (m, m + n_low + n_rows), (m, n_low), (n_low, n_high),
              (n_low, n_rows), (SERIES_TERMS + n_high,))
    return [((*shape, n_designs), np.float64) for shape in shapes]


def levels_launch(levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                  amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined) -> tuple:
    """``levels_kernel``'s launch for ``qsma_kernel.solve_levels``' arguments: its host arguments (those, then
    ``qsma_kernel.level_outputs``) and its work arrays' (shape, dtype) (``level_workspace``)."""
    n_designs, m = linear_per_level.shape
    return ((levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
             amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined,
             *qsma_kernel.level_outputs(n_designs, levels.size, m, stuck)), level_workspace(n_designs, m))


def stuck_launch(joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility,
                 reference_low, reference_high, unambiguous_mac, rows) -> tuple:
    """``stuck_kernel``'s launch for ``stuck_modes.stuck_designs``' arguments: its host arguments (those, the
    designs' shared ``stuck_modes.static_flexibility`` formed here on the CPU, then ``stuck_modes.stuck_outputs``)
    and its work arrays' (shape, dtype) (``stuck_workspace``)."""
    (n_designs, m), n_low, n_high = joint_stiffness.shape, low_modes.shape[1], high_modes.shape[1]
    return ((joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility, reference_low,
             reference_high, unambiguous_mac, rows, *stuck_modes.static_flexibility(high_eigenvalues, flexibility, m),
             *stuck_modes.stuck_outputs(n_designs, m, n_low, n_high, rows.size)),
            stuck_workspace(n_designs, m, n_low, n_high, rows.size))


def worker_gpu(name, n_gpus: int) -> int:
    """The GPU (index) of a dask worker: a LocalCluster names its workers 0, 1, ..., and worker k takes GPU
    k mod n_gpus, so that the workers spread over a machine's GPUs, each GPU shared by as many; any other name
    (a worker started by hand, or no worker: None) takes the first."""
    number = str(name)
    return int(number) % n_gpus if number.isdigit() and n_gpus > 0 else 0


@functools.cache
def select_gpu() -> int:
    """Make this process's kernels run on its GPU (``worker_gpu`` of the dask worker it is, if any:
    ``pipeline.runners.worker_name``), once per process, before its first launch; returns the index."""
    index = worker_gpu(worker_name(), len(cuda.gpus))
    cuda.select_device(index)
    return index


def run(kernel, n_designs: int, arguments, workspace) -> list:
    """``kernel`` on one thread per design, THREADS_PER_BLOCK to a block, on this process's GPU (``select_gpu``),
    with the host ``arguments`` (each numpy array copied to the device, a scalar as it is) and the work arrays
    allocated on the device; returns the arguments as on the device."""
    select_gpu()
    on_device = [cuda.to_device(a) if isinstance(a, np.ndarray) else a for a in arguments]
    work = [cuda.device_array(shape, dtype) for shape, dtype in workspace]
    kernel[max(1, -(-n_designs // THREADS_PER_BLOCK)), THREADS_PER_BLOCK](*on_device, *work)
    return on_device


def require_gpu() -> None:
    """RuntimeError naming the setting unless numba-cuda finds a GPU or runs its simulator."""
    if not cuda.is_available():
        raise RuntimeError(f"{SETTING}: numba-cuda finds no usable CUDA GPU (an NVIDIA driver, and the CUDA "
                           "toolkit's libraries, e.g. the project's `gpu` extra); use device='cpu', or set "
                           "NUMBA_ENABLE_CUDASIM=1 for numba-cuda's simulator (slow: for tests)")


def solve_levels(*arguments):
    """``qsma_kernel.solve_levels`` on the GPU: the same arguments (numpy arrays) and results (numpy arrays)."""
    require_gpu()
    on_device = run(levels_kernel, arguments[1].shape[0], *levels_launch(*arguments))
    return tuple(a.copy_to_host() for a in on_device[LEVEL_INPUTS + 1:])


def stuck_designs(*arguments):
    """``stuck_modes.stuck_designs`` on the GPU: the same arguments (numpy arrays) and results (numpy arrays)."""
    require_gpu()
    on_device = run(stuck_kernel, arguments[0].shape[0], *stuck_launch(*arguments))
    return tuple(a.copy_to_host() for a in on_device[STUCK_INPUTS:])
