"""QSMA levels on CUDA (``nonlinear.qsma_cuda``) against the CPU kernel: in numba-cuda's simulator (a subprocess
with NUMBA_ENABLE_CUDASIM=1, read by numba at import), and on a GPU where there is one.

The simulator runs the CUDA build's Python source as interpreted Python on the CPU: it checks that the device
path (the per-thread work arrays, the device functions' globals, the target's primitives) computes what the CPU
kernel computes, not libdevice's or NVVM's round-off (``benchmarks.gpu_qsma`` measures that on a GPU).
"""

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest
from numba import cuda

from nonlinear.qsma_vectorised import level_solver

RELATIVE = 1e-10
# Every model on the BRB: 4 designs at 6 amplitudes up to deep slip (iwan5's seed gives a jump of the loading
# path, found by its substeps, and levels past it); then the pseudo-inverse of a singular compliance, the
# eigen-decomposition's path (LAPACK on the CPU, Jacobi rotations on the device).
SIMULATED = """
import json, sys
import numpy as np
from nonlinear import qsma_cuda, qsma_kernel
from nonlinear.condensation import joint_space
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import random_designs
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import beam_superelement

space = joint_space(beam_superelement(sys.argv[1]))
amplitudes = np.geomspace(1e-7, 3e-4, 6)
rows = {}
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


def test_cuda_levels_equal_the_cpu_kernel_in_the_simulator(simulated):
    models = {model: row for model, row in simulated.items() if model != "pinv"}
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


def test_cuda_without_a_gpu_says_what_is_missing():
    if cuda.is_available():
        pytest.skip("a CUDA GPU (or the simulator) is available here")
    with pytest.raises(RuntimeError, match=r"device='cuda'"):
        level_solver("cuda")
    with pytest.raises(ValueError, match="expected one of"):
        level_solver("gpu")


@pytest.mark.slow
def test_cuda_levels_equal_the_cpu_kernel_on_a_gpu(beam_roms):
    """200 designs per model on the BRB on a real GPU (numba-cuda compiles the kernel: about a minute)."""
    if numba.config.ENABLE_CUDASIM or not cuda.is_available():
        pytest.skip("no CUDA GPU here (numba.cuda.is_available() is False, or the simulator is on)")
    from nonlinear.condensation import joint_space
    from nonlinear.friction_models import MODEL_NAMES
    from nonlinear.joint import random_designs
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
