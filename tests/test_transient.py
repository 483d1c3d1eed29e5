"""Transient ring-down of the reduced model against QSMA.

Physics checked: below the slip limit a Jenkins joint is linear, so the free decay has the stuck
frequency and the prescribed modal damping; with a five-patch four-parameter Iwan joint (ASB CD1) the
cycle-by-cycle frequency and damping of the ring-down (zero-crossing period and logarithmic decrement,
``nonlinear.decay_cycles``) follow QSMA's backbone within 0.5 % and 10 %. QSMA neglects the coupling of
the other modes and assumes the Masing loop at a steady amplitude; the ring-down has neither
simplification, so their agreement measures QSMA's modelling error, not a numerical one.
"""

import numpy as np
import pytest

from nonlinear.condensation import joint_space
from nonlinear.decay_cycles import decay_cycles
from nonlinear.qsma import qsma_reference
from nonlinear.transient import ring_down
from reduction.superelement import asb_data_folder, read_asb_superelement

IWAN_DESIGN = [200.0, 1e8, -0.3, 0.1, 1e9, 500.0, 3e8, -0.6, 1.0, 1e10, 800.0, 1e9, -0.8, 0.01, 1e9]
JENKINS_DESIGN = [200.0, 1e8, 1e9, 500.0, 3e8, 1e10, 800.0, 1e9, 1e9]


def cd1_space():
    path = asb_data_folder() / "MAT_NULLRED_CD1.mat"
    if not path.exists():
        pytest.skip(f"ASB reduced model not available at {path} (shared data folder absent)")
    return joint_space(read_asb_superelement(path))


def test_stuck_jenkins_ring_down_is_the_linear_mode():
    """Amplitude 1e-7 m kg^0.5 keeps every Jenkins element below 5 % of its slip displacement."""
    space = cd1_space()
    zeta = 2e-3
    stuck = qsma_reference(space, "jenkins", JENKINS_DESIGN, amplitudes=[1e-7])
    assert stuck.slip_ratio.max() < 0.05
    frequency = stuck.stuck_frequency / (2 * np.pi)
    decay = ring_down(space, "jenkins", JENKINS_DESIGN, duration=20 / frequency, time_step=1 / (100 * frequency),
                      initial_modal_velocity=1e-7 * stuck.stuck_frequency, linear_damping=zeta)
    assert decay.unconverged_steps == 0
    cycles = decay_cycles(decay.time, decay.modal_amplitude, cycles=4)
    # Newmark's average acceleration lengthens the period by (omega dt)^2 / 12 = 3.3e-4.
    np.testing.assert_allclose(cycles.natural_frequency_hz, frequency, rtol=5e-4)
    np.testing.assert_allclose(cycles.damping_ratio, zeta, rtol=0.02)


def test_iwan_ring_down_follows_qsma_backbone():
    """30 cycles of the 200 Hz mode from a modal impulse (about 15 s): the decay spans 3e-4 to 2e-4,
    where the joint softens the mode by 0.4-0.5 % and gives it 0.3 % damping (no linear damping)."""
    space = cd1_space()
    frequency = qsma_reference(space, "iwan4", IWAN_DESIGN, amplitudes=[1e-9]).stuck_frequency / (2 * np.pi)
    decay = ring_down(space, "iwan4", IWAN_DESIGN, duration=30 / frequency, time_step=1 / (100 * frequency),
                      initial_modal_velocity=3e-4 * 2 * np.pi * frequency)
    assert decay.unconverged_steps == 0
    cycles = decay_cycles(decay.time, decay.modal_amplitude, cycles=2)
    qsma = qsma_reference(space, "iwan4", IWAN_DESIGN, amplitudes=cycles.amplitude)
    assert qsma.converged.all() and cycles.amplitude.max() > 2.5e-4
    np.testing.assert_allclose(cycles.natural_frequency_hz, qsma.frequency / (2 * np.pi), rtol=5e-3)
    np.testing.assert_allclose(cycles.damping_ratio, qsma.damping, rtol=0.10)
    assert qsma.frequency.min() < 0.998 * qsma.stuck_frequency  # the comparison is in the nonlinear range
