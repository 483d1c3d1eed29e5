"""Stuck modes and QSMA levels on CUDA (``nonlinear.qsma_cuda``) against the CPU kernels: in numba-cuda's simulator (a
subprocess with NUMBA_ENABLE_CUDASIM=1, read by numba at import), compiled to PTX by NVVM without a GPU, and on a
GPU where there is one.

The simulator runs the CUDA build's Python source as interpreted Python on the CPU: it checks that the device
path (the per-thread work arrays, the device functions' globals, the target's primitives) computes what the CPU
kernels compute, not libdevice's or NVVM's round-off (``benchmarks.gpu_qsma`` measures that on a GPU). It does not
check that numba-cuda can compile the source (interpreted, anything Python runs); the PTX test does, for an
H100's compute capability, where NVVM is installed (the CUDA 12 libraries of the project's ``test`` extra).
"""

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest
from numba import cuda

from numba.cuda.cudadrv import nvvm

from nonlinear.compute_devices import kernels

RELATIVE = 1e-10
# Every model on the BRB: 4 designs at 6 amplitudes up to deep slip (iwan5's seed gives a jump of the loading
# path, found by its substeps, and levels past it); then the pseudo-inverse of a singular compliance, the
# eigen-decomposition's path (LAPACK on the CPU, Jacobi rotations on the device).
SIMULATED = """
import json, sys
import numpy as np
from nonlinear import qsma_cuda, qsma_kernel
from nonlinear.condensation import joint_space, stuck_modes
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import patch_elements, random_designs, stuck_stiffness, tangential_rows
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import beam_superelement

space = joint_space(beam_superelement(sys.argv[1]))
amplitudes = np.geomspace(1e-7, 3e-4, 6)
rows = {}
designs = random_designs("iwan4_core", 6, 3, np.random.default_rng(4))
tangents = stuck_stiffness(patch_elements("iwan4_core", designs, space.superelement.patch_groups))
cpu, gpu = (stuck_modes(space, tangents, rows=tangential_rows(space.superelement.n_patches), device=device)
            for device in ("cpu", "cuda"))
rows["stuck"] = {name: bool(np.array_equal(a, b)) for name, a, b in zip(cpu._fields, cpu, gpu)}
rows["stuck_found"] = int(cpu.found.sum())
for model in MODEL_NAMES:
    designs = random_designs(model, 4, 3, np.random.default_rng(1))
    cpu, gpu = (qsma_designs(space, model, designs, amplitudes=amplitudes, linear_damping=1e-3, device=device)
                for device in ("cpu", "cuda"))
    both = np.isfinite(cpu.frequency) & np.isfinite(gpu.frequency)
    rows[model] = {"omega": float(np.abs(gpu.frequency / cpu.frequency - 1)[both].max(initial=0.0)),
                   "zeta": float(np.abs(gpu.damping / cpu.damping - 1)[both].max(initial=0.0)),
                   "converged": int(cpu.converged.sum()), "both": int(both.sum()),
                   "same_reasons": bool(np.array_equal(cpu.reason, gpu.reason)),
                   "reasons": sorted(set(cpu.reason.astype(str).ravel()))}
vectors = np.linalg.qr(np.random.default_rng(2).standard_normal((6, 6)))[0][:, :4]
singular = vectors @ np.diag([1.0, 2.0, 3.0, 5.0]) @ vectors.T
inverses = []
for pseudo_inverse in (qsma_kernel.pseudo_inverse, qsma_cuda.KERNEL["pseudo_inverse"]):
    inverse = np.empty((6, 6))
    pseudo_inverse(singular, inverse, np.empty((6, 12)))
    inverses.append(inverse)
expected = vectors @ np.diag([1.0, 1 / 2, 1 / 3, 1 / 5]) @ vectors.T
rows["pinv"] = [float(np.abs(inverse - expected).max()) for inverse in inverses]
print(json.dumps(rows))
"""


@pytest.fixture(scope="module")
def simulated(beam_roms):
    """The simulator's comparison (about 15 s)."""
    environment = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    run = subprocess.run([sys.executable, "-c", SIMULATED, str(beam_roms / "BRB.npz")], capture_output=True,
                         text=True, env=environment, check=True)
    return json.loads(run.stdout.splitlines()[-1])


def test_cuda_stuck_modes_equal_the_cpu_kernel_in_the_simulator(simulated):
    """Six BRB designs with a stuck core: every output of the stuck modes (eigenvalue, shapes, MAC, compliance,
    found, the count of unstable modes) equal to the bit."""
    assert simulated["stuck"] == dict.fromkeys(simulated["stuck"], True) and len(simulated["stuck"]) == 7
    assert simulated["stuck_found"] == 6


def test_cuda_levels_equal_the_cpu_kernel_in_the_simulator(simulated):
    models = {model: row for model, row in simulated.items() if model not in ("pinv", "stuck", "stuck_found")}
    assert len(models) == 5
    for model, row in models.items():
        assert row["same_reasons"], model
        assert row["both"] == row["converged"] > 0, model
        assert row["omega"] <= RELATIVE and row["zeta"] <= RELATIVE, model
    # the kernel's flags: a jump of iwan5's loading path (its substeps) and the levels past it
    assert {reason.split(":")[0] for reason in models["iwan5"]["reasons"]} >= {"loading path jumps", "past a jump"}


def test_the_device_pseudo_inverse_of_a_singular_compliance_is_the_cpu_s(simulated):
    """Eigenvalues 1 to 5 and two zeros: the pseudo-inverse is well conditioned, both within 1e-14."""
    assert max(simulated["pinv"]) < 1e-14


# Both kernels compiled by NVVM to PTX for an H100 (compute capability 9.0), with the argument types of a BRB
# problem captured from the CPU kernels (numba-cuda compiles a device function for the current GPU's compute
# capability: without a GPU, the lookup is pointed at 9.0).
COMPILED = """
import json, sys, time, types
import numba
import numba.cuda.dispatcher
numba.cuda.dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))
import numpy as np
from numba import cuda
from nonlinear import compute_devices, qsma_cuda
from nonlinear.condensation import joint_space
from nonlinear.joint import random_designs
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import beam_superelement

captured = {}
def capturing(name, kernel):
    def call(*arguments):
        captured[name] = arguments
        return kernel(*arguments)
    return call
compute_devices.CPU = compute_devices.Kernels(capturing("stuck", compute_devices.CPU.stuck_designs),
                                              capturing("levels", compute_devices.CPU.solve_levels))
space = joint_space(beam_superelement(sys.argv[1]))
qsma_designs(space, "iwan5", random_designs("iwan5", 2, 3, np.random.default_rng(0)), amplitudes=[1e-6, 1e-5])
report = {}
for name, kernel, launch in (("stuck", qsma_cuda.stuck_kernel, qsma_cuda.stuck_launch),
                             ("levels", qsma_cuda.levels_kernel, qsma_cuda.levels_launch)):
    arguments, workspace = launch(*captured[name])
    signature = tuple(numba.typeof(a) for a in arguments) + tuple(
        numba.types.Array(numba.from_dtype(np.dtype(dtype)), len(shape), "C") for shape, dtype in workspace)
    start = time.perf_counter()
    ptx, _ = cuda.compile_ptx(kernel.py_func, signature, cc=(9, 0))
    report[name] = {"seconds": time.perf_counter() - start, "entry": f"{kernel.py_func.__name__}" in ptx
                    and ".entry" in ptx, "target": ".target sm_90" in ptx, "float64_ops": ptx.count(".f64")}
print(json.dumps(report))
"""


@pytest.mark.slow
def test_the_cuda_kernels_compile_to_ptx_for_an_h100(beam_roms):
    """numba-cuda types and lowers every device function of the stuck modes and the levels (about 50 s): what the
    simulator cannot check (an array allocated in a device function, a numpy call the CUDA target lacks)."""
    if not nvvm.is_available():
        pytest.skip("NVVM is not installed (the CUDA 12 libraries of the project's `test` or `gpu` extra)")
    run = subprocess.run([sys.executable, "-c", COMPILED, str(beam_roms / "BRB.npz")], capture_output=True,
                         text=True, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    report = json.loads(run.stdout.splitlines()[-1])
    for name in ("stuck", "levels"):
        assert report[name]["entry"] and report[name]["target"], name
        assert report[name]["float64_ops"] > 1000, name  # the whole solver, not an empty kernel


def test_a_clusters_workers_spread_over_the_gpus():
    """A LocalCluster's workers 0, 1, ... take the GPUs in turn; a worker of another name, or no worker, the first."""
    from nonlinear.qsma_cuda import worker_gpu

    assert [worker_gpu(k, 2) for k in range(5)] == [0, 1, 0, 1, 0]
    assert [worker_gpu(k, 1) for k in range(3)] == [0, 0, 0]
    assert worker_gpu("3", 4) == 3 and worker_gpu("tcp://10.0.0.2:4000", 2) == 0 and worker_gpu(None, 3) == 0


def test_cuda_without_a_gpu_says_what_is_missing():
    if cuda.is_available():
        pytest.skip("a CUDA GPU (or the simulator) is available here")
    with pytest.raises(RuntimeError, match=r"device='cuda'"):
        kernels("cuda")
    with pytest.raises(ValueError, match="expected one of"):
        kernels("gpu")


@pytest.mark.slow
def test_cuda_levels_equal_the_cpu_kernel_on_a_gpu(beam_roms):
    """200 designs per model on the BRB on a real GPU, stuck modes and levels (numba-cuda compiles the kernels: about
    a minute)."""
    if numba.config.ENABLE_CUDASIM or not cuda.is_available():
        pytest.skip("no CUDA GPU here (numba.cuda.is_available() is False, or the simulator is on)")
    from nonlinear.condensation import joint_space, stuck_modes
    from nonlinear.friction_models import MODEL_NAMES
    from nonlinear.joint import patch_elements, random_designs, stuck_stiffness
    from nonlinear.qsma_vectorised import qsma_designs
    from reduction.superelement import beam_superelement

    space = joint_space(beam_superelement(beam_roms / "BRB.npz"))
    amplitudes = np.geomspace(7e-6, 1.1e-4, 10)
    for model in MODEL_NAMES:
        designs = random_designs(model, 200, 3, np.random.default_rng(3))
        cpu, gpu = (qsma_designs(space, model, designs, amplitudes=amplitudes, device=device)
                    for device in ("cpu", "cuda"))
        assert np.array_equal(cpu.reason, gpu.reason), model
        both = np.isfinite(cpu.frequency)
        assert np.all(np.abs(gpu.frequency / cpu.frequency - 1)[both] <= RELATIVE), model
        assert np.all(np.abs(gpu.damping / cpu.damping - 1)[both] <= RELATIVE), model
        tangents = stuck_stiffness(patch_elements(model, designs, space.superelement.patch_groups))
        cpu_modes, gpu_modes = (stuck_modes(space, tangents, device=device) for device in ("cpu", "cuda"))
        assert np.array_equal(cpu_modes.found, gpu_modes.found), model
        assert np.all(np.abs(gpu_modes.eigenvalue / cpu_modes.eigenvalue - 1)[cpu_modes.found] <= RELATIVE), model
