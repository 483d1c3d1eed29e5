"""Cycle-by-cycle natural frequency and damping of a free decay: zero-crossing period and logarithmic decrement.

An estimator independent of the Hilbert transform (:mod:`experiment.hilbert`), to cross-check it. Within each
half cycle of a filtered single-mode signal (between consecutive zero crossings, located by linear
interpolation) the extreme value is located by a parabola through the largest sample and its neighbours.
Over a window of ``cycles`` whole cycles:

    f_d = cycles / (t_z[k + 2 cycles] - t_z[k])                (damped frequency from the zero crossings),
    sigma = -slope of ln|x_peak| against t_peak               (decay rate; per cycle: delta = sigma / f_d),
    omega_n = sqrt((2 pi f_d)^2 + sigma^2),   zeta = sigma / omega_n   (= delta / sqrt(4 pi^2 + delta^2)),

the same quasi-linear oscillator as paper Eq. 2. The amplitude is the geometric mean of the peaks in the window,
converted to displacement by dividing by omega^k (k = 0, 1, 2 for displacement, velocity, acceleration).
Windows advance by one cycle, so ``cycles`` consecutive estimates share data.
"""

from __future__ import annotations

import numpy as np

from experiment.hilbert import InstantaneousBackbone, RingDownSignalError
from experiment.ringdown import DISPLACEMENT_ORDER


def zero_crossings(time: np.ndarray, signal: np.ndarray) -> np.ndarray:
    """Times (m,) s at which the (n,) signal changes sign, by linear interpolation between samples."""
    index = np.flatnonzero(np.signbit(signal[1:]) != np.signbit(signal[:-1]))
    fraction = signal[index] / (signal[index] - signal[index + 1])
    return time[index] + fraction * (time[index + 1] - time[index])


def half_cycle_peaks(time: np.ndarray, signal: np.ndarray, crossings: np.ndarray):
    """Time (m - 1,) s and magnitude (m - 1,) of the extreme value between consecutive zero crossings.

    The largest |sample| of each half cycle and its two neighbours are fitted by a parabola, whose vertex
    gives the peak (error of order (2 pi / samples per period)^4 relative for a sinusoid).
    """
    bounds = np.searchsorted(time, crossings)
    peak_times, peak_values = [], []
    for first, last in zip(bounds[:-1], bounds[1:]):
        centre = first + int(np.argmax(np.abs(signal[first:last])))
        centre = min(max(centre, 1), signal.size - 2)
        before, at, after = np.abs(signal[centre - 1:centre + 2])
        curvature = before - 2 * at + after
        shift = 0.5 * (before - after) / curvature if curvature < 0 else 0.0
        peak_times.append(time[centre] + shift * (time[centre + 1] - time[centre]))
        peak_values.append(at - 0.25 * (before - after) * shift)
    return np.array(peak_times), np.array(peak_values)


def decay_cycles(time: np.ndarray, signal: np.ndarray, *, quantity: str = "displacement",
                 cycles: int = 4) -> InstantaneousBackbone:
    """Natural frequency and damping per window of ``cycles`` cycles of a filtered single-mode free decay.

    time: (n,) s; signal: (n,) the decay only (cut to the same interval as the Hilbert estimate, e.g. its
    first and last time, so both see the same data); quantity: "displacement", "velocity" or "acceleration".
    Returns one estimate per window at the window's mid time (amplitude, Hz, fraction of critical).
    """
    if quantity not in DISPLACEMENT_ORDER:
        raise RingDownSignalError(f"quantity '{quantity}' is not one of {sorted(DISPLACEMENT_ORDER)}")
    crossings = zero_crossings(time, signal)
    half = 2 * cycles
    if crossings.size < half + 2:
        raise RingDownSignalError(f"only {crossings.size} zero crossings; a window of {cycles} cycles needs "
                                  f"{half + 2}")
    peak_times, peak_values = half_cycle_peaks(time, signal, crossings)
    starts = np.arange(0, crossings.size - half, 2)
    damped = 2 * np.pi * cycles / (crossings[starts + half] - crossings[starts])
    rates = np.array([-np.polyfit(peak_times[k:k + half], np.log(peak_values[k:k + half]), 1)[0] for k in starts])
    natural = np.hypot(damped, rates)
    amplitude = np.array([np.exp(np.mean(np.log(peak_values[k:k + half]))) for k in starts])
    return InstantaneousBackbone(0.5 * (crossings[starts] + crossings[starts + half]),
                                 amplitude / natural ** DISPLACEMENT_ORDER[quantity],
                                 natural / (2 * np.pi), rates / natural, correlated_samples=cycles)
