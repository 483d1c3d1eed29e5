"""Isolating one mode of a multi-mode ring-down: modal filtering and band-pass filtering.

Modal filtering (paper section 3.1: "accelerometer data ... are transformed, using the experimental mode shapes,
to modal amplitudes"): with Phi the mode shapes at the sensors, y(t) = Phi q(t), so q = Phi^+ y by the
Moore-Penrose pseudo-inverse (least squares when there are more sensors than modes). A single channel, or a
set of sensors without the shapes of all responding modes, is filtered instead by a zero-phase band-pass around
the mode of interest. Both functions work on arrays only.
"""

from __future__ import annotations

import numpy as np
import scipy.signal


class ModalFilterError(ValueError):
    """Mode shapes or a band that cannot isolate the mode."""


def modal_coordinates(signals: np.ndarray, mode_shapes: np.ndarray) -> np.ndarray:
    """Modal coordinates q = Phi^+ y of sensor signals.

    signals: (n_sensors, n_samples), any unit. mode_shapes: (n_sensors, n_modes), n_modes <= n_sensors,
    columns independent. Returns (n_modes, n_samples) in the signal unit divided by the shape's unit.
    """
    signals, mode_shapes = np.atleast_2d(signals), np.asarray(mode_shapes, dtype=float)
    if mode_shapes.ndim == 1:
        mode_shapes = mode_shapes[:, None]
    if mode_shapes.shape[0] != signals.shape[0]:
        raise ModalFilterError(f"mode shapes have {mode_shapes.shape[0]} sensor rows for {signals.shape[0]} signals")
    if np.linalg.matrix_rank(mode_shapes) < mode_shapes.shape[1]:
        raise ModalFilterError("mode shapes at the sensors are linearly dependent: the modes cannot be separated")
    return np.linalg.pinv(mode_shapes) @ signals


def band_pass(signal: np.ndarray, sample_rate: float, low_hz: float, high_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth band-pass of one or more signals along the last axis.

    signal: (..., n_samples). sample_rate, low_hz, high_hz: Hz, 0 < low < high < sample_rate / 2.
    Filtered forward and backward (amplitude response squared, no phase shift, so the envelope and the phase
    of a mode inside the band are kept) with the ends padded by odd reflection of about three periods of the
    lower band edge, which suppresses the start-up transients. Returns the same shape and unit.
    """
    if not 0 < low_hz < high_hz < sample_rate / 2:
        raise ModalFilterError(f"band {low_hz:g}-{high_hz:g} Hz does not fit below the Nyquist frequency "
                         f"{sample_rate / 2:g} Hz")
    sections = scipy.signal.butter(order, [low_hz, high_hz], btype="bandpass", fs=sample_rate, output="sos")
    pad = min(int(3 * sample_rate / low_hz), np.shape(signal)[-1] - 1)
    return scipy.signal.sosfiltfilt(sections, signal, axis=-1, padtype="odd", padlen=pad)


def dominant_shape(signals: np.ndarray) -> np.ndarray:
    """Deflection shape at the sensors of the strongest component of (n_sensors, n_samples) band-passed signals.

    The first left singular vector of the signal matrix (for one mode in the band, its shape at the sensors),
    scaled to +1 at its largest entry, so the modal coordinate y / shape is the displacement of the sensor
    that moves most. Returns (n_sensors,).
    """
    left, _, _ = np.linalg.svd(np.atleast_2d(signals), full_matrices=False)
    shape = left[:, 0]
    return shape / shape[np.argmax(np.abs(shape))]
