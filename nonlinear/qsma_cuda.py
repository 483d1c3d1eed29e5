"""QSMA levels on a CUDA GPU, one thread per design: ``nonlinear.qsma_kernel`` compiled for numba-cuda from the
same Python source as for the CPU.

``device_functions`` takes every numba CPU function defined in a kernel module and compiles its Python function,
unchanged, as a CUDA device function whose globals are a copy of the module's in which every such function is
its device version, so that the helpers call one another's CUDA builds. Two primitives are the target's own
(``TARGET_PRIMITIVES``): the power 2^(exponent log2 base) of ``qsma_kernel._power``, by ``math.exp2`` and
``math.log2`` (numba-cuda has no ``np.exp2``), and the eigen-decomposition of an ill-conditioned compliance in
``qsma_kernel.pseudo_inverse`` (LAPACK's on the CPU), by the Jacobi rotations of
``nonlinear.dense_linear_algebra`` (no LAPACK on the device). ``solve_levels`` takes the arguments of
``qsma_kernel.solve_levels`` and returns what it returns: each thread runs ``qsma_kernel.solve_design`` for its
design on its own work arrays, slices of global arrays with the design on the last axis (neighbouring threads
read neighbouring addresses). The stuck modes (``nonlinear.stuck_modes.stuck_designs``) stay on the CPU.

The numbers are the CPU kernel's to round-off, not to the bit: libdevice's exp2, log2 and pow are not the CPU's,
NVVM fuses multiply-adds (its default) and the Jacobi eigenvectors are not LAPACK's; a level decided at a
threshold (a flag, a substep's regime) can go either way where the two round-offs straddle it.
With NUMBA_ENABLE_CUDASIM=1 the same source runs in numba-cuda's simulator (interpreted Python on the CPU, for
tests without a GPU). Needs the package numba-cuda (the project's ``test`` and ``gpu`` extras).
"""

from __future__ import annotations

import math
import types

import numpy as np
import numba_cuda  # noqa: F401 (the CUDA target package; numba's own numba.cuda is deprecated)
from numba import cuda
from numba.core.registry import CPUDispatcher

from nonlinear import dense_linear_algebra, qsma_kernel
from nonlinear.qsma_kernel import N_LAW, N_WORK_ROWS

THREADS_PER_BLOCK = 64
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


@cuda.jit
def levels_kernel(levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                  amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined, solutions,
                  joint_displacement, slip_ratio, status, amplitude, force, frequency, damping, work, matrix,
                  compliance_pinv, waypoint, stuck_state, dropping, design_compliance, table, stiffness_scaled,
                  core_scaled, active):
    """Thread d solves design d (``qsma_kernel.solve_design``) with the slices [..., d] of the work arrays
    (``design_workspace``)."""
    d = cuda.grid(1)
    if d < defined.size and defined[d]:
        solve_design(d, (levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                         amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load),
                     (solutions, joint_displacement, slip_ratio, status, amplitude, force, frequency, damping),
                     (work[:, :, d], matrix[:, :, d], compliance_pinv[:, :, d], waypoint[:, d], stuck_state[:, d],
                      dropping[:, d], design_compliance[:, :, d], table[:, :, d], stiffness_scaled[:, d],
                      core_scaled[:, d], active[:, d]))


def design_workspace(n_designs: int, m: int) -> tuple:
    """``qsma_kernel.solve_design``'s work arrays for every design on the device, the design on the last axis:
    shapes as there with n_designs appended (stuck state zeros, the rest uninitialised)."""
    return (cuda.device_array((N_WORK_ROWS, m, n_designs)), cuda.device_array((m, 2 * m, n_designs)),
            cuda.device_array((m, m, n_designs)), cuda.device_array((m, n_designs)),
            cuda.to_device(np.zeros((m, n_designs))), cuda.device_array((m, n_designs), dtype=np.bool_),
            cuda.device_array((m, m, n_designs)), cuda.device_array((m, N_LAW, n_designs)),
            cuda.device_array((m, n_designs)), cuda.device_array((m, n_designs)),
            cuda.device_array((m, n_designs), dtype=np.int64))


def require_gpu() -> None:
    """RuntimeError naming the setting unless numba-cuda finds a GPU or runs its simulator."""
    if not cuda.is_available():
        raise RuntimeError(f"{SETTING}: numba-cuda finds no usable CUDA GPU (an NVIDIA driver, and the CUDA "
                           "toolkit's libraries, e.g. the project's `gpu` extra); use device='cpu', or set "
                           "NUMBA_ENABLE_CUDASIM=1 for numba-cuda's simulator (slow: for tests)")


def solve_levels(levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                 amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined):
    """``qsma_kernel.solve_levels`` on the GPU: the same arguments (numpy arrays) and results (numpy arrays)."""
    require_gpu()
    n_designs, m = linear_per_level.shape
    outputs = [cuda.to_device(a) for a in qsma_kernel.level_outputs(n_designs, levels.size, m, stuck)]
    problem = [cuda.to_device(a) if isinstance(a, np.ndarray) else a for a in (
        levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
        amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined)]
    blocks = max(1, -(-n_designs // THREADS_PER_BLOCK))
    levels_kernel[blocks, THREADS_PER_BLOCK](*problem, *outputs, *design_workspace(n_designs, m))
    return tuple(a.copy_to_host() for a in outputs[1:])
