"""Hilbert (FreeVib) backbone extraction against decays whose frequency and damping are known exactly.

Physics checked: a linear viscous decay gives its natural frequency within 0.1 % and its damping ratio within
2 % over zeta = 1e-4 to 1e-2, whether measured as displacement or acceleration and with Eq. 4 or Feldman's
corrections; two closely spaced modes are separated by modal filtering and a well separated one by band-pass;
a damped Duffing oscillator follows its elliptic-integral backbone within 0.5 % in frequency and 10 % in
damping; the cycle-by-cycle estimator agrees; records average with their spread.
"""

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.special import ellipk

from experiment.backbone import average_backbones
from experiment.decay_cycles import decay_cycles
from experiment.hilbert import freevib
from experiment.modal_filter import band_pass, modal_coordinates

SAMPLE_RATE = 4000.0  # Hz: 40 samples per period of the 100 Hz test mode
NOISE = 1e-4  # sensor noise, standard deviation relative to the initial amplitude (80 dB dynamic range)
FREQUENCY_TOLERANCE = 1e-3  # omega within 0.1 %
DAMPING_TOLERANCE = 0.02  # zeta within 2 %


def linear_decay(time, frequency_hz, damping_ratio, phase=0.3, quantity="displacement"):
    """Free decay of a unit-amplitude linear viscous oscillator: displacement, or its exact acceleration."""
    omega = 2 * np.pi * frequency_hz
    sigma, damped = damping_ratio * omega, omega * np.sqrt(1 - damping_ratio**2)
    envelope = np.exp(-sigma * time)
    if quantity == "displacement":
        return envelope * np.cos(damped * time + phase)
    return envelope * ((sigma**2 - damped**2) * np.cos(damped * time + phase)
                       + 2 * sigma * damped * np.sin(damped * time + phase))


def decay_time(frequency_hz, damping_ratio):
    """Record length: five e-folds of the envelope, at most 3 s (ten times the noise-free dynamic range)."""
    return min(3.0, 5.0 / (damping_ratio * 2 * np.pi * frequency_hz))


def noisy(signal, seed):
    """Signal plus seeded white noise of NOISE times its initial magnitude."""
    return signal + NOISE * np.max(np.abs(signal)) * np.random.default_rng(seed).standard_normal(signal.shape)


def grid_of(record, n_points=8):
    """Log amplitude grid inside the range a record covers (bins away from its ends)."""
    return np.geomspace(np.min(record.amplitude) * 1.1, np.max(record.amplitude) / 1.1, n_points)


@pytest.mark.parametrize("feldman", [False, True])
@pytest.mark.parametrize("quantity", ["displacement", "acceleration"])
@pytest.mark.parametrize("damping_ratio", [1e-4, 1e-3, 1e-2])
def test_linear_decay_gives_its_frequency_and_damping(damping_ratio, quantity, feldman):
    frequency_hz = 100.0
    time = np.arange(0, decay_time(frequency_hz, damping_ratio), 1 / SAMPLE_RATE)
    signal = noisy(linear_decay(time, frequency_hz, damping_ratio, quantity=quantity), seed=1)
    filtered = band_pass(signal, SAMPLE_RATE, 70.0, 130.0)
    record = freevib(time, filtered, frequency_hz, quantity=quantity, feldman=feldman)
    backbone = average_backbones([record], grid_of(record))
    assert np.all(np.isfinite(backbone.natural_frequency_hz))
    assert np.max(np.abs(backbone.natural_frequency_hz / frequency_hz - 1)) < FREQUENCY_TOLERANCE
    assert np.max(np.abs(backbone.damping_ratio / damping_ratio - 1)) < DAMPING_TOLERANCE


def test_acceleration_is_converted_to_displacement_amplitude():
    frequency_hz, damping_ratio = 100.0, 1e-3
    time = np.arange(0, 1.0, 1 / SAMPLE_RATE)
    record = freevib(time, linear_decay(time, frequency_hz, damping_ratio, quantity="acceleration"), frequency_hz,
                     quantity="acceleration")
    expected = np.exp(-damping_ratio * 2 * np.pi * frequency_hz * record.time)  # unit initial displacement
    assert np.max(np.abs(record.amplitude / expected - 1)) < 1e-3


def test_noise_floor_is_cut():
    """A decay that sinks into noise is cut where the envelope reaches three times the noise floor."""
    frequency_hz, damping_ratio, noise = 100.0, 1e-2, 1e-3
    time = np.arange(0, 2.0, 1 / SAMPLE_RATE)
    rng = np.random.default_rng(7)
    signal = band_pass(linear_decay(time, frequency_hz, damping_ratio) + noise * rng.standard_normal(time.size),
                       SAMPLE_RATE, 70.0, 130.0)
    record = freevib(time, signal, frequency_hz)
    band_noise = noise * np.sqrt(2 * 60.0 / SAMPLE_RATE)  # noise standard deviation left in the 60 Hz band
    assert np.min(record.amplitude) > 2 * band_noise
    assert record.time[-1] < 0.8 * time[-1]
    backbone = average_backbones([record], grid_of(record, 5))
    assert np.max(np.abs(backbone.damping_ratio / damping_ratio - 1)) < DAMPING_TOLERANCE


def test_closely_spaced_modes_are_separated_by_modal_filtering():
    """Modes 3 % apart on two sensors: the pseudo-inverse of the shapes recovers each mode's decay."""
    frequencies, damping_ratios = np.array([100.0, 103.0]), np.array([2e-3, 5e-3])
    shapes = np.array([[1.0, 0.8], [0.6, -1.0]])  # (sensors, modes)
    time = np.arange(0, 2.0, 1 / SAMPLE_RATE)
    modal = np.array([linear_decay(time, f, z, phase=p) for f, z, p in zip(frequencies, damping_ratios, (0.3, 1.9))])
    sensors = noisy(shapes @ modal, seed=2)
    separated = modal_coordinates(sensors, shapes)
    for coordinate, frequency_hz, damping_ratio in zip(separated, frequencies, damping_ratios):
        record = freevib(time, band_pass(coordinate, SAMPLE_RATE, 80.0, 125.0), frequency_hz)
        backbone = average_backbones([record], grid_of(record))
        assert np.max(np.abs(backbone.natural_frequency_hz / frequency_hz - 1)) < FREQUENCY_TOLERANCE
        assert np.max(np.abs(backbone.damping_ratio / damping_ratio - 1)) < DAMPING_TOLERANCE


def test_well_separated_mode_is_isolated_by_band_pass():
    """One sensor, modes at 100 and 370 Hz (a ratio like the BRB's first two): the band-pass keeps the first."""
    time = np.arange(0, 2.0, 1 / SAMPLE_RATE)
    signal = noisy(linear_decay(time, 100.0, 1.5e-3) + 2.0 * linear_decay(time, 370.0, 1e-3, phase=1.1), seed=3)
    record = freevib(time, band_pass(signal, SAMPLE_RATE, 70.0, 130.0), 100.0)
    backbone = average_backbones([record], grid_of(record))
    assert np.max(np.abs(backbone.natural_frequency_hz / 100.0 - 1)) < FREQUENCY_TOLERANCE
    assert np.max(np.abs(backbone.damping_ratio / 1.5e-3 - 1)) < DAMPING_TOLERANCE


def test_cycle_estimator_gives_linear_frequency_and_damping():
    for damping_ratio in (1e-4, 1e-3, 1e-2):
        time = np.arange(0, decay_time(100.0, damping_ratio), 1 / SAMPLE_RATE)
        filtered = band_pass(noisy(linear_decay(time, 100.0, damping_ratio), seed=4), SAMPLE_RATE, 70.0, 130.0)
        kept = slice(int(12 * SAMPLE_RATE / 100.0), -int(12 * SAMPLE_RATE / 100.0))  # band-pass end effects
        record = decay_cycles(time[kept], filtered[kept])
        backbone = average_backbones([record], grid_of(record))
        assert np.max(np.abs(backbone.natural_frequency_hz / 100.0 - 1)) < FREQUENCY_TOLERANCE
        assert np.max(np.abs(backbone.damping_ratio / damping_ratio - 1)) < DAMPING_TOLERANCE


# Duffing oscillator x'' + 2 zeta0 omega0 x' + omega0^2 x + k3 x^3 = 0 (unit mass), hardening by 8 % at A = 1.
DUFFING_FREQUENCY_HZ, DUFFING_DAMPING = 20.0, 3e-3
OMEGA0 = 2 * np.pi * DUFFING_FREQUENCY_HZ
CUBIC = 0.25 * OMEGA0**2  # 1/(m^2 s^2)


def duffing_frequency(peak):
    """Exact undamped frequency (rad/s) at peak displacement A: x = A cn(Omega t, m), period 4 K(m) / Omega,
    Omega^2 = omega0^2 + k3 A^2, m = k3 A^2 / (2 Omega^2)."""
    stiffness = OMEGA0**2 + CUBIC * peak**2
    return np.pi * np.sqrt(stiffness) / (2 * ellipk(CUBIC * peak**2 / (2 * stiffness)))


def duffing_fundamental(peak):
    """Amplitude of the fundamental harmonic of A cn(u, m): A 2 pi sqrt(q) / (sqrt(m) K (1 + q)), q the nome."""
    parameter = CUBIC * peak**2 / (2 * (OMEGA0**2 + CUBIC * peak**2))
    nome = np.exp(-np.pi * ellipk(1 - parameter) / ellipk(parameter))
    return peak * 2 * np.pi * np.sqrt(nome) / (np.sqrt(parameter) * ellipk(parameter) * (1 + nome))


def duffing_damping(peak):
    """Damping ratio seen by the Hilbert envelope of the fundamental, from the energy balance of one cycle.

    dE/dt = -c <v^2> with <v^2> = (2 omega / pi) A^2 int_0^{pi/2} cos^2(t) sqrt(omega0^2 + k3 A^2 (1 + sin^2 t)
    / 2) dt and dE/dA = omega0^2 A + k3 A^3 give d ln A / dt; the fundamental's envelope decays at that rate
    times d ln a1 / d ln A; zeta = -(d ln a1 / dt) / omega.
    """
    omega = duffing_frequency(peak)
    integral = quad(lambda t: np.cos(t) ** 2 * np.sqrt(OMEGA0**2 + CUBIC * peak**2 * (1 + np.sin(t) ** 2) / 2),
                    0, np.pi / 2)[0]
    mean_square_velocity = 2 * omega / np.pi * peak**2 * integral
    log_rate = 2 * DUFFING_DAMPING * OMEGA0 * mean_square_velocity / ((OMEGA0**2 + CUBIC * peak**2) * peak**2)
    step = 1e-4
    log_slope = np.log(duffing_fundamental(peak * (1 + step)) / duffing_fundamental(peak * (1 - step))) / (
        np.log1p(step) - np.log1p(-step))
    return log_slope * log_rate / omega


def duffing_ring_down():
    """Time (s) and displacement (m) of the damped Duffing oscillator released from x = 1 m, 100 samples/period."""
    time = np.arange(0, 6.0, 1 / (100 * DUFFING_FREQUENCY_HZ))

    def rates(_, state):
        x, v = state
        return [v, -2 * DUFFING_DAMPING * OMEGA0 * v - OMEGA0**2 * x - CUBIC * x**3]

    solution = solve_ivp(rates, (0, time[-1]), [1.0, 0.0], t_eval=time, method="DOP853", rtol=1e-10, atol=1e-12)
    return time, solution.y[0]


@pytest.fixture(scope="module")
def duffing():
    time, displacement = duffing_ring_down()
    filtered = band_pass(displacement, 100 * DUFFING_FREQUENCY_HZ, 0.7 * DUFFING_FREQUENCY_HZ,
                         1.3 * DUFFING_FREQUENCY_HZ)
    return time, filtered


def fundamental_to_peak(fundamental):
    """Peak displacement A whose fundamental harmonic amplitude is ``fundamental`` (monotonic inversion)."""
    peaks = np.geomspace(1e-3, 1.2, 2000)
    return np.interp(fundamental, duffing_fundamental(peaks), peaks)


@pytest.mark.parametrize("estimator", ["hilbert", "hilbert-feldman", "cycles"])
def test_duffing_decay_follows_the_elliptic_backbone(duffing, estimator):
    time, filtered = duffing
    record = freevib(time, filtered, DUFFING_FREQUENCY_HZ, feldman=estimator == "hilbert-feldman")
    if estimator == "cycles":  # on the interval the Hilbert estimate kept, clear of the band-pass end effects
        kept = (time >= record.time[0]) & (time <= record.time[-1])
        record = decay_cycles(time[kept], filtered[kept])
    backbone = average_backbones([record], grid_of(record, 10))
    peaks = fundamental_to_peak(backbone.amplitude)
    expected_frequency = duffing_frequency(peaks) / (2 * np.pi)
    expected_damping = np.array([duffing_damping(peak) for peak in peaks])
    assert expected_frequency[-1] / expected_frequency[0] > 1.03  # the test resolves the nonlinearity
    assert np.max(np.abs(backbone.natural_frequency_hz / expected_frequency - 1)) < 5e-3
    assert np.max(np.abs(backbone.damping_ratio / expected_damping - 1)) < 0.10


def test_backbone_averages_records_with_their_spread():
    """Two hits of one linear decay at different levels: the average is the common value, the spread small."""
    time = np.arange(0, 2.0, 1 / SAMPLE_RATE)
    records = [freevib(time, band_pass(noisy(level * linear_decay(time, 100.0, 2e-3), seed=seed), SAMPLE_RATE,
                                       70.0, 130.0), 100.0)
               for level, seed in ((1.0, 5), (0.7, 6))]
    grid = np.geomspace(0.2, 0.6, 6)
    backbone = average_backbones(records, grid)
    assert np.all(backbone.n_records == 2)
    assert np.max(np.abs(backbone.damping_ratio / 2e-3 - 1)) < DAMPING_TOLERANCE
    assert np.all(backbone.damping_ratio_spread < DAMPING_TOLERANCE * 2e-3)
    assert np.all(backbone.natural_frequency_uncertainty_hz >= backbone.natural_frequency_standard_error_hz)
