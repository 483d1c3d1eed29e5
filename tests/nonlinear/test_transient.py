"""Transient ring-down of the reduced model against QSMA.

Physics checked: below the slip limit a Jenkins joint is linear, so the free decay has the stuck
frequency and the prescribed modal damping; with a five-patch four-parameter Iwan joint (ASB CD1) struck by a
hammer at an accelerometer, the sensor signals processed as a measured ring-down (modal filter with the
linear modes at the sensors, band-pass, Hilbert FreeVib) follow QSMA's backbone within 0.5 % in frequency and
10 % in damping over the amplitudes the Hilbert stage keeps. QSMA neglects the coupling of the other modes and
assumes the Masing loop at a steady amplitude; the ring-down has neither simplification, so their agreement
measures QSMA's modelling error, not a numerical one.

Measured (100 samples per period): the Hilbert frequency is 0.05 % below QSMA's (Newmark's period error is
0.033 %), the damping 2-7 % above it (mean 3.5 %: the other modes the hit excites add slip). The joint couples
the mode to the 573 Hz mode (near 3:1 internal resonance): the hit leaves that mode ringing, its intermodulation
products 3 f_1 - f_3 modulate the envelope at 29 Hz (sidebands at 170 and 228 Hz, 0.3 % of the peak) and
the instantaneous damping by +-10 %. The estimators therefore average over one modulation period (7 periods
of the mode): FreeVib's derivative smoothing and the cycle window; with FreeVib's default 2 periods single
bins reach 11 %.
"""

import numpy as np
import pytest

from experiment.backbone import average_backbones, ringdown_backbone
from experiment.decay_cycles import decay_cycles
from nonlinear.condensation import joint_space
from nonlinear.qsma import qsma_reference
from nonlinear.transient import Hammer, hammer_impulse, ring_down, sensor_modes

IWAN_DESIGN = [200.0, 1e8, -0.3, 0.1, 1e9, 500.0, 3e8, -0.6, 1.0, 1e10, 800.0, 1e9, -0.8, 0.01, 1e9]
JENKINS_DESIGN = [200.0, 1e8, 1e9, 500.0, 3e8, 1e10, 800.0, 1e9, 1e9]
SAMPLES_PER_PERIOD = 100  # Newmark's period error (omega dt)^2 / 12 = 3.3e-4
HIT_SENSOR = 2  # the accelerometer where the tracked (200 Hz) mode moves most
HIT_IMPULSE = 1.0  # N s: the joint softens the mode by 0.75-1 % over the kept decay
CONTACT_TIME = 3e-3  # s: a soft tip, first spectral zero at 500 Hz


@pytest.fixture
def cd1_space(asb_superelement):
    return joint_space(asb_superelement("CD1"))


def modal_filter_shapes(frequencies, shapes, target, n_sensors):
    """Mode shapes at the sensors (n_sensors, n_sensors) for the modal filter, as a modal test would give them:
    the linear modes nearest the target in frequency, one per sensor, the target first."""
    return shapes[:, np.argsort(np.abs(frequencies - frequencies[target]))[:n_sensors]]


def modulation_periods(frequencies, target):
    """Periods of the tracked mode in one period of the envelope modulation by the mode nearest its third
    harmonic, |3 omega_1 - omega_k| (the joint's odd nonlinearity mixes them)."""
    third = np.argmin(np.abs(frequencies - 3 * frequencies[target]))
    return frequencies[target] / abs(3 * frequencies[target] - frequencies[third])


def test_stuck_jenkins_ring_down_is_the_linear_mode(cd1_space):
    """Amplitude 1e-7 m kg^0.5 keeps every Jenkins element below 5 % of its slip displacement."""
    space = cd1_space
    zeta = 2e-3
    stuck = qsma_reference(space, "jenkins", JENKINS_DESIGN, amplitudes=[1e-7])
    assert stuck.slip_ratio.max() < 0.05
    frequency = stuck.stuck_frequency / (2 * np.pi)
    decay = ring_down(space, "jenkins", JENKINS_DESIGN, duration=20 / frequency, time_step=1 / (100 * frequency),
                      initial_modal_velocity=1e-7 * stuck.stuck_frequency, linear_damping=zeta)
    assert decay.unconverged_steps == 0
    cycles = decay_cycles(decay.sensors.time, decay.modal_amplitude, cycles=4)
    # Newmark's average acceleration lengthens the period by (omega dt)^2 / 12 = 3.3e-4.
    np.testing.assert_allclose(cycles.natural_frequency_hz, frequency, rtol=5e-4)
    np.testing.assert_allclose(cycles.damping_ratio, zeta, rtol=0.02)


def test_ideal_impulse_sets_the_momentum_of_every_mode(cd1_space):
    """An ideal hit of I at a sensor gives the structure the momentum I along the sensor's axis: the sensor's
    velocity just after it is I times the point's flexibility to impulses, sum over modes of (influence^T psi)^2
    (the inverse of the point's apparent mass), positive and independent of the joint."""
    space = cd1_space
    sensor = space.superelement.sensors[HIT_SENSOR]
    velocity = hammer_impulse(space, sensor, 2.0)
    point_modes = sensor @ space.modes
    np.testing.assert_allclose(point_modes @ velocity, 2.0 * np.sum(point_modes ** 2), rtol=1e-12)


@pytest.fixture(scope="module")
def hammer_ring_down(asb_superelement):
    """60 periods of the 200 Hz mode after a soft hammer hit at an accelerometer (about 30 s): the decay the
    Hilbert stage needs (12 periods trimmed at each end, 2 x 10 for its noise-floor blocks). Its sensor
    signals go through the same function as a measured file: modal filter with the linear modes at the
    sensors, band-pass of +-30 %, FreeVib, and the cycle estimator on the interval FreeVib keeps, both
    averaging over one modulation period. Returns the space, the decay and its one record."""
    space = joint_space(asb_superelement("CD1"))
    frequencies, shapes, target = sensor_modes(space, "iwan4", IWAN_DESIGN)
    period = 2 * np.pi / frequencies[target]
    hammer = Hammer(space.superelement.sensors[HIT_SENSOR], HIT_IMPULSE, CONTACT_TIME)
    decay = ring_down(space, "iwan4", IWAN_DESIGN, duration=60 * period, time_step=period / SAMPLES_PER_PERIOD,
                      hammer=hammer)
    smoothing = modulation_periods(frequencies, target)
    mode_shapes = modal_filter_shapes(frequencies, shapes, target, len(decay.sensors.channels))
    backbone = ringdown_backbone([decay.sensors], frequencies[target] / (2 * np.pi), mode_shapes=mode_shapes,
                                 smoothing_periods=smoothing, cycles=int(round(smoothing)))
    return space, decay, backbone.records[0]


def test_hammer_ring_down_processed_by_hilbert_follows_qsma(hammer_ring_down):
    """Frequency within 0.5 % and damping within 10 % of QSMA on eight amplitude bins spanning the samples
    that FreeVib keeps (after the envelope maximum, 12 periods trimmed at both ends: the clean decay)."""
    space, decay, record = hammer_ring_down
    assert decay.unconverged_steps == 0
    hilbert = record.hilbert
    grid = np.geomspace(hilbert.amplitude.min() * 1.05, hilbert.amplitude.max() / 1.05, 8)
    backbone = average_backbones([hilbert], grid)
    qsma = qsma_reference(space, "iwan4", IWAN_DESIGN, amplitudes=grid)
    assert qsma.converged.all()
    assert qsma.frequency.max() < 0.995 * qsma.stuck_frequency  # softer than the tolerance: nonlinear range
    assert qsma.damping[-1] > 1.25 * qsma.damping[0]
    np.testing.assert_allclose(backbone.natural_frequency_hz, qsma.frequency / (2 * np.pi), rtol=5e-3)
    np.testing.assert_allclose(backbone.damping_ratio, qsma.damping, rtol=0.10)


def test_cycle_estimator_on_the_hammer_ring_down_follows_qsma(hammer_ring_down):
    """The zero-crossing / log-decrement estimator on the same filtered decay and interval, windows of one
    modulation period, agrees too."""
    space, decay, record = hammer_ring_down
    cycles = record.cycles
    qsma = qsma_reference(space, "iwan4", IWAN_DESIGN, amplitudes=cycles.amplitude[::-1])
    assert qsma.converged.all()
    np.testing.assert_allclose(cycles.natural_frequency_hz, qsma.frequency[::-1] / (2 * np.pi), rtol=5e-3)
    np.testing.assert_allclose(cycles.damping_ratio, qsma.damping[::-1], rtol=0.10)
