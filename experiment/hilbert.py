"""Amplitude-dependent natural frequency and damping from a free decay by the Hilbert transform (FreeVib).

Paper section 3.1, Eqs. 1-4 (after Feldman 1994, "FreeVib"): a single-mode ring-down u(t) = A(t) cos(psi(t))
(Eq. 1) is taken as the response of a quasi-linear oscillator u'' + 2 zeta(A) omega(A) u' + omega(A)^2 u = 0
(Eq. 2). The analytic signal u + i H[u] gives the envelope A(t) and phase psi(t), and (Eq. 4)

    omega_n = sqrt(psi'^2 + (ln A)'^2),        zeta = -(ln A)' / omega_n,

which is exact for a linear decay. Feldman's FreeVib corrections (optional) also account for the variation of
omega along the decay:

    omega_0^2 = omega^2 - A''/A + 2 (A'/A)^2 + A' omega' / (A omega),   h = -A'/A - omega' / (2 omega),
    zeta = h / omega_0,   with omega = psi'.

Processing of one filtered single-mode signal (:func:`freevib`): mirror-padded analytic signal; derivatives by
Savitzky-Golay smoothing over a whole number of periods; velocity or acceleration envelopes converted to
displacement amplitude by dividing by omega or omega^2 before ln A is differentiated; the start (before the
envelope maximum, e.g. the impact) and both ends (end effects of the transform and of the smoothing) trimmed;
the noise floor detected where the envelope stops decaying and cut. Several records (hits, channels) are
averaged on one amplitude grid by :func:`experiment.backbone.average_backbones`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from experiment.ringdown import DISPLACEMENT_ORDER


class RingDownSignalError(ValueError):
    """A signal from which no backbone can be extracted (too short, under-sampled, no decay)."""


OPTION_MINIMA = {"smoothing_periods": 0.5, "trim_periods": 0.0, "block_periods": 1.0, "noise_floor_factor": 1.0}
"""Smallest value of each time-scale option of :func:`freevib` (a derivative window of half a period at least)."""


@dataclass(frozen=True)
class InstantaneousBackbone:
    """One decay's estimates before any averaging: natural frequency and damping at each sample (FreeVib) or
    each window of cycles (:func:`experiment.decay_cycles.decay_cycles`), not binned and without an uncertainty;
    :func:`experiment.backbone.average_backbones` averages records of them into a
    :class:`~experiment.backbone.Backbone`.

    time: (n,) s. amplitude: (n,) displacement amplitude, unit of the displacement the signal stands for
    (m for a sensor in SI units; modal amplitude for a modal coordinate). natural_frequency_hz: (n,) Hz.
    damping_ratio: (n,) fraction of critical. correlated_samples: how many consecutive estimates share data
    (the smoothing window), so that n / correlated_samples of them are independent. onset: the time of the decay's
    start, its envelope maximum (a hammer hit's impact), s; None where not known.
    """

    time: np.ndarray
    amplitude: np.ndarray
    natural_frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    correlated_samples: int = 1
    onset: float | None = None


def samples_per_period(sample_rate: float, frequency_hz: float) -> float:
    """Number of samples in one period of ``frequency_hz``."""
    return sample_rate / frequency_hz


def odd_window(length: float) -> int:
    """The odd integer window length nearest to ``length`` (at least 5 samples)."""
    return max(5, 2 * int(round(length / 2)) + 1)


def smoothed_derivative(values: np.ndarray, step: float, window: int, order: int = 1) -> np.ndarray:
    """Derivative of a sampled function by a Savitzky-Golay quadratic (cubic for order 2) local fit.

    values: (n,), step: sample spacing, s; window: odd number of samples. Returns (n,) d^order values / dt^order.
    """
    return scipy.signal.savgol_filter(values, window, polyorder=order + 1, deriv=order, delta=step,
                                      mode="interp")


def oscillation_extension(signal: np.ndarray, n_fit: int, n_extend: int) -> np.ndarray:
    """Continuation of a (n,) oscillation past its last sample by a second-order linear prediction.

    x[j] = c1 x[j-1] + c2 x[j-2] is fitted by least squares over the last ``n_fit`` samples (exact for one
    damped sinusoid); its pole pair is limited to unit modulus, so the continuation never grows, then it is
    run for ``n_extend`` samples. Returns (n_extend,).
    """
    segment = signal[-n_fit:]
    c1, c2 = np.linalg.lstsq(np.column_stack([segment[1:-1], segment[:-2]]), segment[2:], rcond=None)[0]
    poles = np.roots([1.0, -c1, -c2])
    poles = poles / np.maximum(np.abs(poles), 1.0)
    c1, c2 = np.real(poles.sum()), -np.real(poles.prod())
    extended = list(signal[-2:])
    for _ in range(n_extend):
        extended.append(c1 * extended[-1] + c2 * extended[-2])
    return np.array(extended[2:])


def analytic_signal(signal: np.ndarray, period: float) -> np.ndarray:
    """Analytic signal u + i H[u] (paper Eq. 1) of a (n,) single-mode signal with the end effects suppressed.

    period: samples per period. The FFT-based discrete Hilbert transform treats the record as periodic, and the
    jump between a decay's large start and small end leaks into the whole record with a 1/t tail. Here the
    record is continued at both ends by :func:`oscillation_extension` (fitted on three periods) over twenty
    periods, faded to zero with a half-Hann taper, so the periodic extension is smooth; the extension is
    then cut off again.
    """
    n_fit, n_extend = int(3 * period), int(20 * period)
    taper = np.sin(np.linspace(0.0, np.pi / 2, n_extend)) ** 2
    head = oscillation_extension(signal[::-1], n_fit, n_extend)[::-1] * taper
    tail = oscillation_extension(signal, n_fit, n_extend) * taper[::-1]
    return scipy.signal.hilbert(np.concatenate([head, signal, tail]))[n_extend:n_extend + signal.size]


def slow_part(z: np.ndarray, sample_rate: float, cutoff_hz: float) -> np.ndarray:
    """The slow part z_1 (n,) of an analytic signal z (n,) sampled at ``sample_rate`` (Hz): exp of the zero-phase
    low-pass (Butterworth, 4th order, ``cutoff_hz``) of ln|z| + i psi, each about its straight line through the
    ends so that the padding continues it. For one mode and noise, the mode without the noise above the cut-off."""
    log = np.log(np.abs(z)) + 1j * np.unwrap(np.angle(z))
    line = log[0] + (log[-1] - log[0]) * np.linspace(0.0, 1.0, z.size)
    sections = scipy.signal.butter(4, cutoff_hz, btype="lowpass", fs=sample_rate, output="sos")
    pad = min(int(3 * sample_rate / cutoff_hz), z.size - 1)
    rest = log - line
    smooth = (scipy.signal.sosfiltfilt(sections, rest.real, padtype="odd", padlen=pad)
              + 1j * scipy.signal.sosfiltfilt(sections, rest.imag, padtype="odd", padlen=pad))
    return np.exp(line + smooth)


def decay_end(envelope: np.ndarray, block: int, relative_drop: float = 1e-4) -> int:
    """Index where the envelope stops decaying: the end of the last block before medians stop falling.

    envelope: (n,) amplitude; block: samples per block (a whole number of periods, so ripple at the
    oscillation frequency cancels in the median). A block counts as decaying when its median is below the
    previous block's by more than ``relative_drop`` (which corresponds to a damping ratio of
    relative_drop / (2 pi periods per block)). Returns n when the envelope decays to the end.
    """
    n_blocks = envelope.size // block
    medians = np.median(envelope[:n_blocks * block].reshape(n_blocks, block), axis=1)
    rising = np.flatnonzero(medians[1:] >= medians[:-1] * (1 - relative_drop))
    return envelope.size if rising.size == 0 else (rising[0] + 1) * block


def decay_interval(envelope: np.ndarray, tail: int, block: int, noise_floor_factor: float) -> tuple[int, int]:
    """Sample interval [start, stop) of the free decay in a (n,) rough envelope.

    start: the envelope maximum (the impact), searched before the last ``tail`` samples. stop: where the decay
    ends (:func:`decay_end`); when noise follows, its median envelope is the noise floor and the decay is cut
    where the envelope first falls below ``noise_floor_factor`` times that floor.
    """
    start = int(np.argmax(envelope[:envelope.size - tail]))
    stop = start + decay_end(envelope[start:], block)
    if stop < envelope.size:
        below = np.flatnonzero(envelope[start:stop] < noise_floor_factor * np.median(envelope[stop:]))
        stop = start + below[0] if below.size else stop
    return start, stop


def freevib(time: np.ndarray, signal: np.ndarray, mode_frequency_hz: float, *, quantity: str = "displacement",
            smoothing_periods: float = 2.0, trim_periods: float = 12.0, block_periods: float = 10.0,
            noise_floor_factor: float = 3.0, feldman: bool = False) -> InstantaneousBackbone:
    """Instantaneous natural frequency and damping along a single-mode free decay (paper Eqs. 1-4).

    time: (n,) s, uniformly sampled. signal: (n,) one mode only (filter first: :mod:`experiment.modal_filter`),
    a displacement, velocity or acceleration as given by ``quantity``. mode_frequency_hz: a guess of the
    mode's natural frequency, Hz, which sets the time scales below.
    smoothing_periods: Savitzky-Golay window of the derivatives, in periods.
    trim_periods: periods cut at both ends of the decay: end effects of the transform, of the smoothing and of
    a preceding zero-phase band-pass, whose end transients move ln A by more than 2 % of zeta omega for about
    ten periods after a 4th-order band-pass of +-30 % of the mode frequency (measured on synthetic decays).
    block_periods: block length, in periods, of the noise-floor detection (:func:`decay_end`); after the decay
    ends, the median envelope is the noise floor, and samples below ``noise_floor_factor`` times it are cut.
    feldman: use Feldman's FreeVib corrections instead of Eq. 4.
    Returns the properties on the kept samples; the amplitude is the displacement amplitude A / omega^k
    (k = 0, 1, 2 for displacement, velocity, acceleration). Raises RingDownSignalError when the record is
    too short or too coarsely sampled for the mode, or does not decay.
    """
    time, signal = np.asarray(time, dtype=float), np.asarray(signal, dtype=float)
    if time.ndim != 1 or signal.shape != time.shape:
        raise RingDownSignalError(f"time {time.shape} and signal {signal.shape} must be vectors of one length")
    if quantity not in DISPLACEMENT_ORDER:
        raise RingDownSignalError(f"quantity '{quantity}' is not one of {sorted(DISPLACEMENT_ORDER)}")
    values = {"smoothing_periods": smoothing_periods, "trim_periods": trim_periods, "block_periods": block_periods,
              "noise_floor_factor": noise_floor_factor}
    for option, value in values.items():
        minimum = OPTION_MINIMA[option]
        if not np.isfinite(value) or value < minimum:
            raise RingDownSignalError(f"option {option} = {value!r}: expected a finite number >= {minimum:g}")
    step = (time[-1] - time[0]) / (time.size - 1)
    period = samples_per_period(1 / step, mode_frequency_hz)
    if period < 8:
        raise RingDownSignalError(f"{period:.1f} samples per period of the {mode_frequency_hz:g} Hz mode; at least "
                                  "8 are needed (sampling too slow for this mode)")
    needed = 2 * trim_periods + 2 * block_periods + smoothing_periods
    if time.size < needed * period:
        raise RingDownSignalError(f"{time.size / period:.1f} periods of the {mode_frequency_hz:g} Hz mode; at least "
                                  f"{needed:g} are needed (record too short for this mode)")
    window = odd_window(smoothing_periods * period)
    trim, block = int(trim_periods * period), int(block_periods * period)
    start, stop = decay_interval(np.abs(scipy.signal.hilbert(signal)), int(needed * period), block,
                                 noise_floor_factor)
    if stop - start < 2 * block + 2 * trim:
        raise RingDownSignalError(f"no decay: the envelope falls for only {(stop - start) / period:.1f} periods "
                                  f"after its maximum at t = {time[start]:.4g} s; at least "
                                  f"{2 * (block_periods + trim_periods):g} are needed")
    analytic = analytic_signal(signal[start:stop], period)
    omega = smoothed_derivative(np.unwrap(np.angle(analytic)), step, window)
    envelope = np.abs(analytic) / np.abs(omega) ** DISPLACEMENT_ORDER[quantity]
    if feldman:
        natural, damping = feldman_properties(envelope, omega, step, window)
    else:
        log_rate = smoothed_derivative(np.log(envelope), step, window)
        natural = np.hypot(omega, log_rate)
        damping = -log_rate / natural
    kept = slice(trim, stop - start - trim)
    return InstantaneousBackbone(time[start:stop][kept], envelope[kept], natural[kept] / (2 * np.pi),
                                 damping[kept], correlated_samples=window, onset=float(time[start]))


def feldman_properties(envelope: np.ndarray, omega: np.ndarray, step: float, window: int):
    """Feldman's FreeVib undamped natural frequency omega_0 (rad/s) and damping ratio h / omega_0 (n,).

    envelope: (n,) displacement amplitude A; omega: (n,) instantaneous frequency psi', rad/s; step: s.
    omega_0^2 = omega^2 - A''/A + 2 (A'/A)^2 + A' omega' / (A omega); h = -A'/A - omega' / (2 omega).
    """
    rate = smoothed_derivative(envelope, step, window) / envelope
    curvature = smoothed_derivative(envelope, step, window, order=2) / envelope
    chirp = smoothed_derivative(omega, step, window) / omega
    natural = np.sqrt(omega**2 - curvature + 2 * rate**2 + rate * chirp)
    return natural, (-rate - chirp / 2) / natural
