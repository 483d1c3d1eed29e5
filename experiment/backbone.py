"""Backbone of one mode from a measured ring-down file: filtering, both estimators, averaging, CSV and plot.

Paper section 3.1 and Fig. 3: the ring-downs of several hammer hits are filtered to one mode, the Hilbert
(FreeVib) estimator gives natural frequency and damping against displacement amplitude, and the hits are
averaged on one amplitude grid. The cycle-by-cycle estimator (:mod:`experiment.decay_cycles`) runs on the same
filtered data as an independent check. Problems with a file or with one of its channels raise
:class:`~experiment.ringdown_files.RingDownFileError` naming the file and the channel.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from experiment.decay_cycles import decay_cycles
from experiment.hilbert import (Backbone, InstantaneousBackbone, RingDownSignalError, amplitude_grid,
                               average_backbones, freevib)
from experiment.modal_filter import ModalFilterError, band_pass, dominant_shape, modal_coordinates
from experiment.ringdown_files import RingDown, RingDownFileError, read_ringdown
from pipeline.files import atomic_path


@dataclass(frozen=True)
class ModeRecord:
    """One filtered decay of the mode (one hit, one channel or the modal coordinate) and both estimates."""

    label: str
    hilbert: InstantaneousBackbone
    cycles: InstantaneousBackbone


@dataclass(frozen=True)
class MeasuredBackbone:
    """Backbones of one mode of a ring-down file, averaged over its records.

    amplitude_unit: unit of the grid (displacement of the sensor that moves most when the shape is
    estimated). shape: the mode shape at the sensors used, channel -> value. hilbert, cycles: the two
    estimators on one grid.
    """

    source: str
    mode_frequency_hz: float
    amplitude_unit: str
    shape: dict
    records: list[ModeRecord] = field(repr=False)
    hilbert: Backbone = field(repr=False)
    cycles: Backbone = field(repr=False)


def mode_signals(record: RingDown, mode_frequency_hz: float, band_hz: tuple[float, float],
                 mode_shapes: np.ndarray | None, mode_index: int, per_channel: bool):
    """Filtered single-mode signals of one hit: list of (label, (n_samples,) signal), and the shape used.

    With ``mode_shapes`` (n_channels, n_modes) the hit is modally filtered (pseudo-inverse) and column
    ``mode_index`` kept; otherwise the channels are band-passed and the mode's shape is estimated from them
    (:func:`~experiment.modal_filter.dominant_shape`). ``per_channel`` keeps each channel divided by its shape
    entry as a separate record (a check of consistency between sensors) instead of one modal coordinate.
    """
    low, high = band_hz
    if mode_shapes is not None:
        if not 0 <= mode_index < mode_shapes.shape[1]:
            raise ModalFilterError(f"mode {mode_index + 1} requested of {mode_shapes.shape[1]} mode shapes")
        modal = modal_coordinates(record.signals, mode_shapes)[mode_index]
        shape = mode_shapes[:, mode_index]
        return [(f"{record.hit}: mode {mode_index + 1}", band_pass(modal, record.sample_rate, low, high))], shape
    filtered = band_pass(record.signals, record.sample_rate, low, high)
    shape = dominant_shape(filtered)
    if per_channel:
        return [(f"{record.hit}: {name}", signal / value)
                for name, signal, value in zip(record.channels, filtered, shape)], shape
    return [(f"{record.hit}: modal", modal_coordinates(filtered, shape)[0])], shape


def estimate_record(source: str, label: str, time: np.ndarray, signal: np.ndarray, mode_frequency_hz: float,
                    quantity: str, cycles: int, freevib_options: dict) -> ModeRecord:
    """Both estimators on one filtered decay; the cycle estimator sees the interval the Hilbert one kept."""
    try:
        hilbert = freevib(time, signal, mode_frequency_hz, quantity=quantity, **freevib_options)
        kept = (time >= hilbert.time[0]) & (time <= hilbert.time[-1])
        return ModeRecord(label, hilbert, decay_cycles(time[kept], signal[kept], quantity=quantity, cycles=cycles))
    except RingDownSignalError as error:
        raise RingDownFileError(source, label, str(error)) from error


def measured_backbone(path: Path, mode_frequency_hz: float, *, band_hz: tuple[float, float] | None = None,
                      mode_shapes: np.ndarray | None = None, mode_index: int = 0, per_channel: bool = False,
                      channels: list[str] | None = None, grid_points: int = 25, cycles: int = 4,
                      **freevib_options) -> MeasuredBackbone:
    """Backbone of one mode of a ring-down file (CSV, .mat, UFF 58), averaged over hits (and channels).

    mode_frequency_hz: guess of the mode's natural frequency, Hz. band_hz: band-pass edges, Hz (default
    0.7 and 1.3 times the guess). mode_shapes: (n_channels, n_modes) shapes at the selected channels for modal
    filtering, or None to estimate the shape. channels: names to use (default all). grid_points: size of the
    log-spaced amplitude grid. cycles: window of the cycle estimator. freevib_options: passed to
    :func:`~experiment.hilbert.freevib` (smoothing_periods, trim_periods, feldman, ...).
    """
    band_hz = band_hz or (0.7 * mode_frequency_hz, 1.3 * mode_frequency_hz)
    hits = [selected_channels(hit, channels) for hit in read_ringdown(path)] if channels else read_ringdown(path)
    records, shapes = [], []
    for hit in hits:
        try:
            signals, shape = mode_signals(hit, mode_frequency_hz, band_hz, mode_shapes, mode_index, per_channel)
        except ModalFilterError as error:
            raise RingDownFileError(path, "band / mode shapes", str(error)) from error
        shapes.append(shape)
        records += [estimate_record(str(path), label, hit.time, signal, mode_frequency_hz, hit.quantity, cycles,
                                    freevib_options) for label, signal in signals]
    grid = amplitude_grid([record.hilbert for record in records], grid_points)
    return MeasuredBackbone(str(path), mode_frequency_hz, "m" if mode_shapes is None else "m / shape unit",
                            dict(zip(hits[0].channels, np.mean(shapes, axis=0))), records,
                            average_backbones([record.hilbert for record in records], grid),
                            average_backbones([record.cycles for record in records], grid))


def selected_channels(hit: RingDown, channels: list[str]) -> RingDown:
    """The hit restricted to the named channels, in that order."""
    missing = sorted(set(channels) - set(hit.channels))
    if missing:
        raise RingDownFileError(hit.source, ", ".join(missing), f"no such channel (the file has {hit.channels})")
    rows = [hit.channels.index(name) for name in channels]
    return RingDown(hit.source, hit.hit, hit.time, hit.signals[rows], tuple(channels), hit.quantity)


CSV_COLUMNS = (
    ("amplitude", "{unit}", lambda b: b.hilbert.amplitude),
    ("records", "-", lambda b: b.hilbert.n_records),
    ("natural_frequency_hilbert", "Hz", lambda b: b.hilbert.natural_frequency_hz),
    ("natural_frequency_hilbert_spread", "Hz", lambda b: b.hilbert.natural_frequency_spread_hz),
    ("natural_frequency_hilbert_uncertainty", "Hz", lambda b: b.hilbert.natural_frequency_uncertainty_hz),
    ("damping_ratio_hilbert", "-", lambda b: b.hilbert.damping_ratio),
    ("damping_ratio_hilbert_spread", "-", lambda b: b.hilbert.damping_ratio_spread),
    ("damping_ratio_hilbert_uncertainty", "-", lambda b: b.hilbert.damping_ratio_uncertainty),
    ("natural_frequency_cycles", "Hz", lambda b: b.cycles.natural_frequency_hz),
    ("natural_frequency_cycles_spread", "Hz", lambda b: b.cycles.natural_frequency_spread_hz),
    ("natural_frequency_cycles_uncertainty", "Hz", lambda b: b.cycles.natural_frequency_uncertainty_hz),
    ("damping_ratio_cycles", "-", lambda b: b.cycles.damping_ratio),
    ("damping_ratio_cycles_spread", "-", lambda b: b.cycles.damping_ratio_spread),
    ("damping_ratio_cycles_uncertainty", "-", lambda b: b.cycles.damping_ratio_uncertainty),
)
"""Columns of the backbone CSV: name, unit, value."""


def write_backbone_csv(backbone: MeasuredBackbone, destination: Path) -> None:
    """Write the averaged backbones as CSV, header ``name [unit]``.

    spread: standard deviation over records (hits, channels); uncertainty: spread and the estimator's
    standard error within the amplitude bin in quadrature (:class:`~experiment.hilbert.Backbone`).
    """
    with atomic_path(destination) as temporary, open(temporary, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow([f"{name} [{unit.format(unit=backbone.amplitude_unit)}]" for name, unit, _ in CSV_COLUMNS])
        writer.writerows(zip(*(np.asarray(value(backbone)) for _, _, value in CSV_COLUMNS)))


def low_amplitude_reference(values: np.ndarray) -> float:
    """The value at the lowest grid amplitude that has data (paper Fig. 3's low-amplitude value)."""
    return values[np.flatnonzero(np.isfinite(values))[0]]


def plot_backbone(backbone: MeasuredBackbone, destination: Path) -> None:
    """Paper Fig. 3 style PNG: frequency deviation (%) and damping deviation from the low-amplitude values
    against amplitude on a log axis; Hilbert mean with its spread shaded, cycle estimates with error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (frequency_axis, damping_axis) = plt.subplots(2, 1, sharex=True, figsize=(6, 6))
    f0 = low_amplitude_reference(backbone.hilbert.natural_frequency_hz)
    z0 = low_amplitude_reference(backbone.hilbert.damping_ratio)
    for estimate, name, style in ((backbone.hilbert, "Hilbert (FreeVib)", "-"), (backbone.cycles, "cycles", "o")):
        frequency = 100 * (estimate.natural_frequency_hz / f0 - 1)
        frequency_spread = np.nan_to_num(100 * estimate.natural_frequency_spread_hz / f0)
        damping, damping_spread = estimate.damping_ratio - z0, np.nan_to_num(estimate.damping_ratio_spread)
        if style == "-":
            frequency_axis.plot(estimate.amplitude, frequency, style, label=name)
            frequency_axis.fill_between(estimate.amplitude, frequency - frequency_spread,
                                        frequency + frequency_spread, alpha=0.3)
            damping_axis.plot(estimate.amplitude, damping, style, label=name)
            damping_axis.fill_between(estimate.amplitude, damping - damping_spread, damping + damping_spread,
                                      alpha=0.3)
        else:
            frequency_axis.errorbar(estimate.amplitude, frequency, frequency_spread, fmt=style, ms=3, label=name)
            damping_axis.errorbar(estimate.amplitude, damping, damping_spread, fmt=style, ms=3, label=name)
    frequency_axis.set_ylabel("frequency deviation (%)")
    damping_axis.set_ylabel("damping deviation (-)")
    damping_axis.set_xlabel(f"amplitude ({backbone.amplitude_unit})")
    damping_axis.set_xscale("log")
    frequency_axis.set_title(f"{Path(backbone.source).name}\nlow-amplitude {f0:.3f} Hz, damping ratio {z0:.2e}",
                             fontsize=10)
    frequency_axis.legend()
    figure.tight_layout()
    with atomic_path(destination) as temporary:
        figure.savefig(temporary, dpi=120, format="png")
    plt.close(figure)
