"""Standard errors of FreeVib's bin means from twin decays: the record's own mode with fresh noise at its own level.

The errors of the Hilbert estimates along a decay are neither independent nor stationary: the estimates are
derivatives of the smoothed phase and log envelope, so their errors cancel along an amplitude bin (a bin mean's
error is that of the bin's ends over its duration), while the scatter within a bin also holds the backbone's own
change across it and the estimator's ripple. Rather than model that, FreeVib is run on twins of each record whose
content is known (a parametric bootstrap):

- the twin's mode is the slow part z_1 of the record's analytic signal over the decay
  (:func:`experiment.hilbert.slow_part`, cut-off ``TWIN_BANDWIDTH`` times the mode frequency), the record before the
  decay (pre-trigger, impact) kept as it is;
- its noise is Gaussian, band-passed like the record, of the record's own level: the median absolute residual
  |y - Re z_1| over the decay times 1.4826 (a normal spread), divided by sqrt(1 - 2 f_c / B) for the share of the
  noise the low-pass keeps in z_1 (f_c the cut-off, B the band's width);
- its known natural frequency and damping are those of z_1 (paper Eq. 4 on its phase and displacement envelope).

The standard error of a record's bin mean is the standard deviation of the twins' bin means, in quadrature with
their mean error against their known content (the estimator's bias on a decay of this shape):
``experiment.backbone.twin_standard_errors``. Seeded: the twins of one record draw from
``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import inspect

import numpy as np
import scipy.signal

from experiment.hilbert import RingDownSignalError, analytic_signal, decay_interval, freevib, slow_part
from experiment.modal_filter import band_pass
from experiment.ringdown import DISPLACEMENT_ORDER

TWIN_BANDWIDTH = 0.05  # cut-off of the twin's mode (ln z low-passed), fraction of the mode frequency
TWINS = 16  # twins per record


def twin_mode(time: np.ndarray, signal: np.ndarray, mode_frequency_hz: float, band_hz, quantity: str,
              freevib_options: dict):
    """The twin's noise-free signal (n,), the noise's standard deviation after the band-pass, and the known
    natural frequency (Hz) and damping ratio of its mode, as functions of time over the decay: (signal, level,
    decay time (m,), natural frequency (m,), damping (m,)). time, signal: one band-passed record (n,)."""
    options = {name: parameter.default for name, parameter in inspect.signature(freevib).parameters.items()
               if parameter.default is not inspect.Parameter.empty} | freevib_options
    step = time[1] - time[0]
    period = 1.0 / (step * mode_frequency_hz)
    needed = 2 * options["trim_periods"] + 2 * options["block_periods"] + options["smoothing_periods"]
    start, stop = decay_interval(np.abs(scipy.signal.hilbert(signal)), int(needed * period),  # FreeVib's interval
                                 int(options["block_periods"] * period), options["noise_floor_factor"])
    cutoff = TWIN_BANDWIDTH * mode_frequency_hz
    mode = slow_part(analytic_signal(signal[start:stop], period), 1.0 / step, cutoff)
    level = 1.4826 * np.median(np.abs(signal[start:stop] - mode.real)) / np.sqrt(
        1.0 - 2.0 * cutoff / (band_hz[1] - band_hz[0]))
    twin = np.concatenate([signal[:start], mode.real, np.zeros(signal.size - stop)])
    omega = np.gradient(np.unwrap(np.angle(mode)), step)
    log_rate = np.gradient(np.log(np.abs(mode) / np.abs(omega) ** DISPLACEMENT_ORDER[quantity]), step)
    natural = np.hypot(omega, log_rate)
    return twin, level, time[start:stop], natural / (2 * np.pi), -log_rate / natural


def twin_estimates(time: np.ndarray, signal: np.ndarray, mode_frequency_hz: float, band_hz, quantity: str,
                   freevib_options: dict, seed: int = 0, twins: int = TWINS) -> list[tuple]:
    """FreeVib on ``twins`` twins of one record (module docstring): a list of (estimate, its known natural
    frequency (n,) Hz, its known damping ratio (n,)), one per twin FreeVib accepts. time, signal: the record (n,)
    as FreeVib saw it (band-passed, or modally filtered and band-passed)."""
    twin, level, decay_time, natural_hz, damping = twin_mode(time, signal, mode_frequency_hz, band_hz, quantity,
                                                             freevib_options)
    sample_rate = 1.0 / (time[1] - time[0])
    rng = np.random.default_rng(seed)
    scale = level / np.std(band_pass(rng.standard_normal(signal.size), sample_rate, *band_hz))
    estimates = []
    for _ in range(twins):
        noisy = twin + scale * band_pass(rng.standard_normal(signal.size), sample_rate, *band_hz)
        try:
            estimate = freevib(time, noisy, mode_frequency_hz, quantity=quantity, **freevib_options)
        except RingDownSignalError:
            continue  # a twin whose decay FreeVib refuses has no estimate to add
        estimates.append((estimate, np.interp(estimate.time, decay_time, natural_hz),
                          np.interp(estimate.time, decay_time, damping)))
    return estimates
