"""Backbone of one mode from ring-downs: filtering, both estimators, averaging over hits and channels.

Paper section 3.1 and Fig. 3: the ring-downs of several hammer hits are filtered to one mode, the Hilbert
(FreeVib) estimator (:mod:`experiment.hilbert`) gives natural frequency and damping against displacement
amplitude, and the hits are averaged on one amplitude grid with their spread. The cycle-by-cycle estimator
(:mod:`experiment.decay_cycles`) runs on the same filtered data as an independent check.

:func:`ringdown_backbone` is the one path from signals to a backbone, for measured files (read by
:mod:`experiment.ringdown_files`) and simulated decays (:func:`nonlinear.transient.ring_down`) alike. Problems
with a record or one of its channels raise :class:`~experiment.ringdown.RingDownError` naming its source and
the record.

The types, from one decay to a study's input: :class:`~experiment.hilbert.InstantaneousBackbone` (one decay's
estimates, before averaging), :class:`Backbone` (the points of a backbone with their spread and standard error),
:class:`RingDownBackbones` (what :func:`ringdown_backbone` gives: both estimators' backbones and their records),
:class:`ModeBackbone` (one structure's backbone labelled for a study: structure, low-amplitude frequency,
provenance, source; its file format is in :mod:`experiment.backbone_files`); the study reduces the last to
levels (``study.structures.BackboneLevels``).
"""

from __future__ import annotations

import warnings
from dataclasses import astuple, dataclass, field

import numpy as np

from experiment.decay_cycles import decay_cycles
from experiment.hilbert import OPTION_MINIMA, InstantaneousBackbone, RingDownSignalError, freevib
from experiment.modal_filter import ModalFilterError, band_pass, dominant_shape, modal_coordinates
from experiment.ringdown import RingDown, RingDownError, selected_channels
from experiment.twin_decays import twin_estimates

PROVENANCES = ("measured", "virtual", "unknown")
"""Where a backbone comes from: a physical test, or a simulated test of a model (a virtual experiment)."""


@dataclass(frozen=True)
class Backbone:
    """The points of a backbone: natural frequency and damping against amplitude, each with its spread and
    standard error, unlabelled (the structure, provenance and source are :class:`ModeBackbone`'s).

    From ring-downs (:func:`average_backbones`) the points are the bins of an amplitude grid averaged over the
    records (hits or channels); from a file or a model (an ASB backbone, QSMA, the nonlinear mode) they are the
    points as given, one record each, their spread and standard error NaN where not known.

    amplitude: (n_grid,) grid amplitudes. natural_frequency_hz, damping_ratio: (n_grid,) means over the records
    that reach that amplitude (NaN where none does). *_spread: (n_grid,) sample standard deviations of the
    records' bin means (NaN where fewer than two): the hit-to-hit (or sensor-to-sensor) variation.
    *_standard_error: (n_grid,) standard error of the bin mean: the estimator's own noise (from twin decays of the
    records, :func:`twin_standard_errors`, or the pooled scatter, :func:`binned_standard_error`).
    n_records: (n_grid,) records contributing.
    """

    amplitude: np.ndarray
    natural_frequency_hz: np.ndarray
    natural_frequency_spread_hz: np.ndarray
    natural_frequency_standard_error_hz: np.ndarray
    damping_ratio: np.ndarray
    damping_ratio_spread: np.ndarray
    damping_ratio_standard_error: np.ndarray
    n_records: np.ndarray

    def with_data(self) -> "Backbone":
        """The grid points that at least one record reaches (a backbone to fit has no empty points)."""
        kept = self.n_records > 0
        return Backbone(*(np.asarray(values)[kept] for values in astuple(self)))

    @property
    def natural_frequency_uncertainty_hz(self) -> np.ndarray:
        """Standard uncertainty (n_grid,) of the mean natural frequency, Hz (:func:`mean_uncertainty`)."""
        return mean_uncertainty(self.natural_frequency_spread_hz, self.natural_frequency_standard_error_hz,
                                self.n_records)

    @property
    def damping_ratio_uncertainty(self) -> np.ndarray:
        """Standard uncertainty (n_grid,) of the mean damping ratio (:func:`mean_uncertainty`)."""
        return mean_uncertainty(self.damping_ratio_spread, self.damping_ratio_standard_error, self.n_records)


def mean_uncertainty(spread: np.ndarray, standard_error: np.ndarray, n_records: np.ndarray) -> np.ndarray:
    """Standard uncertainty of a mean over records (n_grid,): the larger of spread / sqrt(n_records) and the
    estimator's standard error (either one where the other is NaN, as the spread of fewer than two records; NaN
    where neither is known).

    A record's bin mean is the backbone plus the record's own departure (hit-to-hit variation, variance tau^2)
    plus the estimator's error (its share of the mean's variance, se^2); the records' sample variance s^2
    estimates tau^2 + n se^2, so the mean's variance tau^2 / n + se^2 is s^2 / n where the records differ beyond
    the estimator's noise and se^2 where they do not: the larger of the two (a random-effects mean). The spread
    itself is the scatter of one record, sqrt(n) times the mean's where the records agree within their noise.
    """
    spread = np.asarray(spread, dtype=float) / np.sqrt(np.maximum(np.asarray(n_records, float), 1.0))
    return np.fmax(spread, standard_error)


def amplitude_bins(grid: np.ndarray) -> np.ndarray:
    """Bin edges (n_grid + 1,) around an increasing positive amplitude grid: geometric midpoints."""
    grid = np.asarray(grid, dtype=float)
    inner = np.sqrt(grid[1:] * grid[:-1])
    return np.concatenate([[grid[0] ** 2 / inner[0]], inner, [grid[-1] ** 2 / inner[-1]]])


def binned_means(amplitude: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (n,) over the samples whose ``amplitude`` (n,) falls in each grid bin; NaN if none."""
    index = np.digitize(amplitude, amplitude_bins(grid)) - 1
    inside = (index >= 0) & (index < grid.size)
    counts = np.bincount(index[inside], minlength=grid.size)
    sums = np.bincount(index[inside], weights=values[inside], minlength=grid.size)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def values_at_grid(amplitudes: list[np.ndarray], values: list[np.ndarray], grid: np.ndarray) -> np.ndarray:
    """Each record's value at each grid amplitude (n_records, n_grid), from its samples in the grid point's bin;
    NaN where it has none.

    amplitudes, values: one (n_r,) array per record. A record's bin mean is not its value at the grid point g
    where it covers only part of the bin (the top and bottom bins always: the grid ends at the data's ends; a hit
    whose kept decay starts inside a bin), where its samples crowd to one side (the decay is faster at one end),
    or where the backbone curves across the bin. With u = ln a - ln g and the backbone near g the quadratic
    c0 + c1 u + c2 u^2 (least squares over every record's samples in the bin and its two neighbours), the record's
    value at g is its bin mean less c1 mean(u) + c2 mean(u^2) over its own samples in the bin.
    """
    edges = np.log(amplitude_bins(grid))
    logs = [np.log(a) for a in amplitudes]
    index = [np.digitize(u, edges) - 1 for u in logs]
    pooled_log, pooled_values, pooled_index = (np.concatenate(arrays) for arrays in (logs, values, index))
    at_grid = np.full((len(logs), grid.size), np.nan)
    for k, centre in enumerate(np.log(grid)):
        near = np.abs(pooled_index - k) <= 1
        shape = _local_quadratic(pooled_log[near] - centre, pooled_values[near])
        for r, (u, v, i) in enumerate(zip(logs, values, index)):
            inside = i == k
            if inside.any():
                offset = u[inside] - centre
                at_grid[r, k] = np.mean(v[inside] - shape[0] * offset - shape[1] * offset ** 2)
    return at_grid


def _local_quadratic(offset: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """(c1, c2) of the least-squares c0 + c1 u + c2 u^2 through (offset u, values); of a straight line where the
    offsets do not determine a curvature, and (0, 0) where they do not determine a slope."""
    for degree in (2, 1):
        if np.unique(offset).size > degree and np.ptp(offset) > 0:
            coefficients = np.polynomial.polynomial.polyfit(offset, values, degree)
            return float(coefficients[1]), float(coefficients[2]) if degree == 2 else 0.0
    return 0.0, 0.0


def binned_standard_error(amplitude: np.ndarray, values: np.ndarray, independent: np.ndarray,
                          grid: np.ndarray) -> np.ndarray:
    """Standard error of the mean of ``values`` (n,) within each grid bin of ``amplitude`` (n,); NaN if empty.

    independent: (n,) weight of each estimate as an independent one (1 / correlated_samples of its record); the
    bin's scatter is divided by the square root of the summed weights (at least one). For derivative estimates
    (FreeVib's) this overstates the error (docs/design.md section 6): the fallback of :func:`average_backbones`.
    """
    mean = binned_means(amplitude, values, grid)
    index = np.clip(np.digitize(amplitude, amplitude_bins(grid)) - 1, 0, grid.size - 1)
    scatter = np.sqrt(binned_means(amplitude, (values - mean[index]) ** 2, grid))
    inside = (amplitude >= amplitude_bins(grid)[0]) & (amplitude < amplitude_bins(grid)[-1])
    n_independent = np.bincount(index[inside], weights=independent[inside], minlength=grid.size)
    return scatter / np.sqrt(np.maximum(n_independent, 1.0))


def average_backbones(records: list[InstantaneousBackbone], grid: np.ndarray, standard_errors=None) -> Backbone:
    """Backbone on an amplitude grid (n_grid,), averaged over records (paper Fig. 3: seven hammer hits).

    Each record is first averaged within the grid's bins (geometric midpoints), then the records are averaged
    with the sample standard deviation as spread. standard_errors: (frequency (n_grid,) Hz, damping (n_grid,)) of
    the mean, e.g. from the records' twins (:func:`twin_standard_errors`); where they are NaN or not given, the
    standard error pools all instantaneous estimates of a bin (:func:`binned_standard_error`, which overstates it).
    """
    grid = np.asarray(grid, dtype=float)
    amplitude, frequency_hz, damping_ratio = (np.concatenate([getattr(r, name) for r in records])
                                              for name in ("amplitude", "natural_frequency_hz", "damping_ratio"))
    independent = np.concatenate([np.full(r.amplitude.size, 1 / r.correlated_samples) for r in records])
    amplitudes = [r.amplitude for r in records]
    frequency, frequency_spread, count = record_statistics(
        values_at_grid(amplitudes, [r.natural_frequency_hz for r in records], grid))
    damping, damping_spread, _ = record_statistics(values_at_grid(amplitudes, [r.damping_ratio for r in records], grid))
    pooled = [binned_standard_error(amplitude, values, independent, grid) for values in (frequency_hz, damping_ratio)]
    errors = pooled if standard_errors is None else [np.where(np.isfinite(given), given, fallback)
                                                    for given, fallback in zip(standard_errors, pooled)]
    return Backbone(grid, frequency, frequency_spread, errors[0], damping, damping_spread, errors[1], count)


def record_statistics(values: np.ndarray):
    """Mean, sample standard deviation and count over records of (n_records, n_grid) values with NaN gaps.

    Returns three (n_grid,) arrays; the mean is NaN without records, the spread NaN with fewer than two.
    """
    count = np.sum(np.isfinite(values), axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(values, axis=0)
        spread = np.nanstd(values, axis=0, ddof=1)
    return mean, np.where(count > 1, spread, np.nan), count


def amplitude_grid(records: list[InstantaneousBackbone], n_points: int) -> np.ndarray:
    """Log-spaced grid (n_points,): the geometric centres of n_points equal bins in ln a that span the amplitudes
    covered by any of the records, so that the end points lie inside the data, half a bin from its ends (where
    the estimates carry the transform's end effects), not on them."""
    low = min(np.min(r.amplitude) for r in records)
    high = max(np.max(r.amplitude) for r in records)
    edges = np.geomspace(low, high, n_points + 1)
    return np.sqrt(edges[1:] * edges[:-1])


@dataclass(frozen=True)
class ModeRecord:
    """One filtered decay of the mode (one hit, one channel or the modal coordinate), both estimates, and the
    Hilbert estimates of its twins with their known content (:func:`experiment.twin_decays.twin_estimates`)."""

    label: str
    hilbert: InstantaneousBackbone
    cycles: InstantaneousBackbone
    twins: list = field(default_factory=list, repr=False)


@dataclass(frozen=True)
class RingDownBackbones:
    """What :func:`ringdown_backbone` gives: both estimators' backbones of one mode of ring-downs on one grid
    (Hilbert, which a study reads through :func:`mode_backbone`, and the cycle-by-cycle check), the per-decay
    records they average and how the signals were filtered; for measured and simulated ring-downs alike.

    source: the ring-downs' sources. mode_frequency_hz: the guess the processing was set up with, Hz.
    amplitude_unit: unit of the grid (displacement of the sensor that moves most when the shape is
    estimated). shape: the mode shape at the sensors used, channel -> value. hilbert, cycles: the two
    estimators on one grid. band_hz: the band-pass edges the signals were filtered with, Hz (None: not recorded).
    """

    source: str
    mode_frequency_hz: float
    amplitude_unit: str
    shape: dict
    records: list[ModeRecord] = field(repr=False)
    hilbert: Backbone = field(repr=False)
    cycles: Backbone = field(repr=False)
    band_hz: tuple[float, float] | None = None


def mode_signals(record: RingDown, band_hz: tuple[float, float], mode_shapes: np.ndarray | None, mode_index: int,
                 per_channel: bool):
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
                    quantity: str, cycles: int, freevib_options: dict, band_hz, seed: int) -> ModeRecord:
    """Both estimators on one filtered decay (the cycle estimator on the interval the Hilbert one kept), and FreeVib
    on its twins (:mod:`experiment.twin_decays`, drawn from ``seed``)."""
    try:
        hilbert = freevib(time, signal, mode_frequency_hz, quantity=quantity, **freevib_options)
        kept = (time >= hilbert.time[0]) & (time <= hilbert.time[-1])
        return ModeRecord(label, hilbert, decay_cycles(time[kept], signal[kept], quantity=quantity, cycles=cycles),
                          twin_estimates(time, signal, mode_frequency_hz, band_hz, quantity, freevib_options, seed))
    except RingDownSignalError as error:
        raise RingDownError(source, label, str(error)) from error


def twin_standard_errors(records: list[ModeRecord], grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors (n_grid,) of the Hilbert backbone's natural frequency (Hz) and damping ratio, the mean over
    records of their bin means, from each record's twins (:mod:`experiment.twin_decays`): per record, the
    standard deviation of the twins' bin means in quadrature with their mean error against their known content;
    over records, sqrt(sum se_r^2) / n. NaN where no record has two twins in the bin."""
    per_record = []
    for record in records:
        binned = np.array([[values_at_grid([twin.amplitude], [values], grid)[0] for values in
                            (twin.natural_frequency_hz, twin.damping_ratio, frequency, damping)]
                           for twin, frequency, damping in record.twins]).reshape(-1, 4, grid.size)
        reached = np.sum(np.isfinite(binned[:, 0]), axis=0) >= 2
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            spread = np.nanstd(binned[:, :2], axis=0, ddof=1)
            bias = np.nanmean(binned[:, :2] - binned[:, 2:], axis=0)
        per_record.append(np.where(reached, np.hypot(spread, bias), np.nan))
    per_record = np.array(per_record)
    count = np.sum(np.isfinite(per_record), axis=0)
    combined = np.where(count > 0, np.sqrt(np.nansum(per_record ** 2, axis=0)) / np.maximum(count, 1), np.nan)
    return combined[0], combined[1]


def check_identified(record: ModeRecord, band_hz: tuple[float, float], source: str) -> None:
    """Refuse an estimate that is not the mode asked for: its median natural frequency outside the band (the
    band held no decaying mode, and what was estimated is a neighbour's leakage), or a negative median damping
    (the signal grows: not a free decay). Raises RingDownError naming the source, the record and the options."""
    frequency = float(np.median(record.hilbert.natural_frequency_hz))
    damping = float(np.median(record.hilbert.damping_ratio))
    if not band_hz[0] <= frequency <= band_hz[1]:
        raise RingDownError(source, record.label, f"identified {frequency:.2f} Hz lies outside the band "
                            f"{band_hz[0]:.2f}-{band_hz[1]:.2f} Hz set by --mode-hz / --band: no decaying mode "
                            "there; give the mode's frequency")
    if damping <= 0.0:
        raise RingDownError(source, record.label, f"identified damping ratio {damping:.3g} <= 0 (the signal does not "
                            "decay): not a free decay of this mode")


class BackboneSettingError(ValueError):
    """A backbone setting out of range: ``parameter`` (the keyword of :func:`ringdown_backbone` or of
    :func:`~experiment.hilbert.freevib`), its ``value`` and what was ``expected``."""

    def __init__(self, parameter: str, value, expected: str):
        self.parameter, self.value, self.expected = parameter, value, expected
        super().__init__(f"{parameter} = {value!r}: expected {expected}")


def checked_settings(mode_frequency_hz: float, band_hz=None, grid_points: int = 25, cycles: int = 4,
                     mode_index: int = 0, smoothing_periods: float = 2.0, trim_periods: float = 12.0
                     ) -> tuple[float, float]:
    """The band-pass edges (Hz; default 0.7 and 1.3 times the mode frequency), after refusing settings that can
    give no backbone, before any signal is read: a mode frequency that is not a positive finite number, a band
    that is not finite or does not enclose it, fewer than 2 grid points, fewer than 1 cycle per window, a negative
    mode index, or FreeVib time scales below their minima (``experiment.hilbert.OPTION_MINIMA``). Raises
    BackboneSettingError naming the first setting refused."""
    if not (np.isfinite(mode_frequency_hz) and mode_frequency_hz > 0):
        raise BackboneSettingError("mode_frequency_hz", mode_frequency_hz, "a positive natural frequency in Hz")
    band = tuple(band_hz) if band_hz is not None else (0.7 * mode_frequency_hz, 1.3 * mode_frequency_hz)
    if band_hz is not None and not (np.all(np.isfinite(band)) and 0 < band[0] < mode_frequency_hz < band[1]):
        raise BackboneSettingError("band_hz", list(band),
                                   f"finite edges LOW < HIGH in Hz around the mode frequency {mode_frequency_hz:g}")
    for parameter, value, minimum in (("grid_points", grid_points, 2), ("cycles", cycles, 1),
                                      ("mode_index", mode_index, 0)):
        if value < minimum:
            raise BackboneSettingError(parameter, value, f"an integer >= {minimum}")
    for parameter, value in (("smoothing_periods", smoothing_periods), ("trim_periods", trim_periods)):
        if not (np.isfinite(value) and value >= OPTION_MINIMA[parameter]):
            raise BackboneSettingError(parameter, value, f"a finite number of periods >= {OPTION_MINIMA[parameter]:g}")
    return band


def check_nyquist(hits: list[RingDown], band_hz: tuple[float, float],
                  set_by: str = "the mode frequency or the band") -> None:
    """Refuse a band-pass that reaches a hit's Nyquist frequency, naming the hit's file and what ``set_by`` the
    band (RingDownError)."""
    for hit in hits:
        if band_hz[1] >= hit.sample_rate / 2:
            raise RingDownError(hit.source, "time", f"sampled at {hit.sample_rate:g} Hz: the band {band_hz[0]:g}-"
                                f"{band_hz[1]:g} Hz set by {set_by} must lie below its Nyquist frequency "
                                f"{hit.sample_rate / 2:g} Hz")


def ringdown_backbone(hits: list[RingDown], mode_frequency_hz: float, *,
                      band_hz: tuple[float, float] | None = None, mode_shapes: np.ndarray | None = None,
                      mode_index: int = 0, per_channel: bool = False, channels: list[str] | None = None,
                      grid_points: int = 25, cycles: int = 4, seed: int = 0, **freevib_options) -> RingDownBackbones:
    """Backbone of one mode from ring-downs (several hits, each with one or more channels), with its spread.

    hits: ring-downs of one structure with the same channels, measured or simulated. mode_frequency_hz: guess
    of the mode's natural frequency, Hz. band_hz: band-pass edges, Hz (default 0.7 and 1.3 times the guess).
    mode_shapes: (n_channels, n_modes) shapes at the selected channels for modal filtering, or None to estimate
    the shape. mode_index: column of ``mode_shapes`` that is the mode. per_channel: each channel (divided by
    its shape entry) is a record of its own instead of one modal coordinate per hit. channels: names to use
    (default all). grid_points: size of the log-spaced amplitude grid. cycles: window of the cycle estimator.
    seed: of the twins' noise (:mod:`experiment.twin_decays`; record k draws from seed + k), whose spread is the
    Hilbert backbone's standard error (:func:`twin_standard_errors`).
    freevib_options: passed to :func:`~experiment.hilbert.freevib` (smoothing_periods, trim_periods, feldman,
    ...). Returns both estimators averaged over the records on one grid (:func:`average_backbones`). Settings
    are checked first (:func:`checked_settings`, :func:`check_nyquist`).
    """
    band_hz = checked_settings(mode_frequency_hz, band_hz, grid_points, cycles, mode_index,
                               **{key: freevib_options[key] for key in ("smoothing_periods", "trim_periods")
                                  if key in freevib_options})
    hits = [selected_channels(hit, channels) for hit in hits] if channels else hits
    check_nyquist(hits, band_hz)
    records, shapes = [], []
    for hit in hits:
        if not np.any(hit.signals):
            raise RingDownError(hit.source, hit.hit, f"all channels are zero ({', '.join(hit.channels)}): no signal "
                                "to analyse")
        try:
            signals, shape = mode_signals(hit, band_hz, mode_shapes, mode_index, per_channel)
        except ModalFilterError as error:
            raise RingDownError(hit.source, "band / mode shapes", str(error)) from error
        shapes.append(shape)
        for label, signal in signals:
            records.append(estimate_record(hit.source, label, hit.time, signal, mode_frequency_hz, hit.quantity,
                                           cycles, freevib_options, band_hz, seed + len(records)))
            check_identified(records[-1], band_hz, hit.source)
    grid = amplitude_grid([record.hilbert for record in records], grid_points)
    return RingDownBackbones(", ".join(dict.fromkeys(hit.source for hit in hits)), mode_frequency_hz,
                             "m" if mode_shapes is None else "m / shape unit",
                             dict(zip(hits[0].channels, np.mean(shapes, axis=0))), records,
                             average_backbones([record.hilbert for record in records], grid,
                                               twin_standard_errors(records, grid)),
                             average_backbones([record.cycles for record in records], grid), tuple(band_hz))


def low_amplitude_reference(values: np.ndarray) -> float:
    """The value at the lowest grid amplitude that has data (paper Fig. 3's low-amplitude value)."""
    return values[np.flatnonzero(np.isfinite(values))[0]]


@dataclass(frozen=True)
class ModeBackbone:
    """The backbone of one mode of one structure, labelled with what a study needs to compare it with a model:
    what a backbone file holds (:func:`experiment.backbone_files.read_backbone`, ``read_asb_backbone``), what
    :func:`mode_backbone` makes of a ring-down's Hilbert backbone and what the study and the discrepancy loop read
    (reduced to their levels, :class:`study.structures.BackboneLevels`).

    structure: name of the structure (e.g. "ASB C1", "BRB"). low_amplitude_frequency_hz: the mode's natural
    frequency at the lowest amplitude with data, Hz. amplitude_unit: unit of ``backbone.amplitude`` (a
    mass-normalised modal amplitude is in m kg^0.5). provenance: one of :data:`PROVENANCES`. source: what it
    was obtained from (file, or model and design). backbone: the points with their spread. settings: how the
    backbone was estimated (e.g. the band and windows of :func:`ringdown_backbone`; empty where not recorded).
    findings: what the checks of the ring-down's signals saw beside the backbone, ``{"checked": [names],
    "found": [findings]}`` (:func:`experiment.signal_checks.ringdown_findings`; empty where not checked).
    dropped: the estimates left out of ``backbone`` because no free decay of the mode can give them, one
    ``{"amplitude", "natural_frequency_hz", "damping_ratio", "records", "reason"}`` each
    (:func:`physical_backbone`; empty where none was).
    """

    structure: str
    low_amplitude_frequency_hz: float
    amplitude_unit: str
    provenance: str
    source: str
    backbone: Backbone = field(repr=False)
    settings: dict = field(default_factory=dict, repr=False)
    findings: dict = field(default_factory=dict, repr=False)
    dropped: list = field(default_factory=list, repr=False)

    def __post_init__(self):
        if self.provenance not in PROVENANCES:
            raise ValueError(f"provenance '{self.provenance}' is not one of {PROVENANCES}")


def unphysical_points(backbone: Backbone, band_hz: tuple[float, float] | None = None) -> dict[int, str]:
    """The points of a backbone that no free decay of the mode can give, index -> reason: no record reaching the
    amplitude (NaN frequency or damping), a negative damping ratio (the estimate grows there: noise or a
    neighbour's beating, not a decay), a natural frequency outside the band-pass ``band_hz`` (Hz; the filter passes
    no such decay), or not positive where no band is known."""
    low, high = band_hz if band_hz is not None else (0.0, np.inf)
    reasons = {}
    for index, (frequency, damping) in enumerate(zip(backbone.natural_frequency_hz, backbone.damping_ratio)):
        if not (np.isfinite(frequency) and np.isfinite(damping)):
            reasons[index] = "no record reaches this amplitude (no estimate)"
        elif damping < 0.0:
            reasons[index] = f"damping ratio {damping:.3g} < 0: the estimate grows there, not a free decay"
        elif not low < frequency < high:
            reasons[index] = (f"natural frequency {frequency:.6g} Hz outside the band-pass {low:g}-{high:g} Hz: "
                              "the filtered signal holds no such decay" if band_hz is not None else
                              f"natural frequency {frequency:.6g} Hz is not positive")
    return reasons


def physical_backbone(backbone: Backbone, band_hz: tuple[float, float] | None = None) -> tuple[Backbone, list]:
    """The backbone without its :func:`unphysical_points`, and the points left out, each as ``{"amplitude",
    "natural_frequency_hz", "damping_ratio", "records", "reason"}`` (NaN values as None: strict JSON)."""
    reasons = unphysical_points(backbone, band_hz)
    kept = np.array([index not in reasons for index in range(backbone.amplitude.size)], dtype=bool)
    dropped = [{"amplitude": float(backbone.amplitude[index]),
                **{name: (float(value) if np.isfinite(value) else None) for name, value in (
                    ("natural_frequency_hz", backbone.natural_frequency_hz[index]),
                    ("damping_ratio", backbone.damping_ratio[index]))},
                "records": int(backbone.n_records[index]), "reason": reason} for index, reason in reasons.items()]
    return Backbone(*(np.asarray(values)[kept] for values in astuple(backbone))), dropped


def mode_backbone(measured: RingDownBackbones, structure: str, provenance: str, settings: dict | None = None,
                  findings: dict | None = None) -> ModeBackbone:
    """The Hilbert (FreeVib) backbone of a :func:`ringdown_backbone` result, labelled for a study, with the
    ``settings`` it was estimated with and the ``findings`` of the signal checks beside it. The points no free
    decay of the mode can give (:func:`unphysical_points` within the result's band-pass) are left out of it and
    listed in ``dropped`` with their reason. Raises ValueError naming the source where no point is left."""
    backbone, dropped = physical_backbone(measured.hilbert, measured.band_hz)
    if backbone.amplitude.size == 0:
        raise ValueError(f"{measured.source}: no point of the backbone is one a free decay gives (the first: "
                         f"{dropped[0]['reason']}); no backbone to write")
    return ModeBackbone(structure, float(low_amplitude_reference(backbone.natural_frequency_hz)),
                        measured.amplitude_unit, provenance, measured.source, backbone, dict(settings or {}),
                        dict(findings or {}), dropped)
