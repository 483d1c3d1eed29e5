"""What a backbone hides: checks of a ring-down's signals beside its backbone, each a named finding with evidence.

A backbone holds one mode's natural frequency and damping against amplitude. Three things pass through it unseen
and are checked on the signals instead (docs/design.md section 6):

second_mode
    A second mode in the band of the target, beating with it (a modal filter may project it out of the backbone).
    Each hit's band-passed channels y (C, n) are taken over the target's decay, from the envelope maximum of its
    modal coordinate (the impact, t_0) to its noise floor; flat channels (one value throughout) are left out.
    Several channels: the target is the strongest component, of shape s (the first left singular vector of y),
    and the residual is y projected on an orthonormal basis B of the complement of s, e = B^T y (C - 1
    components): the target is removed whatever its amplitude-dependent frequency and damping, and a mode of
    another shape stays in e coherently over the channels, while sensor noise is independent per channel; z_1 is
    the analytic signal of the target's modal coordinate q = s^T y / s^T s. Each
    channel's noise variance sigma_c^2 (pooled over the hits, below) makes the components independent and of
    equal noise, e <- R^-1 e with R R^T = B^T diag(sigma^2) B. One channel: e = z - z_1, z the analytic signal and
    z_1 its slow part (ln z low-passed at ``TREND_BANDWIDTH`` times the mode frequency). Each component j of hit k
    (analytic signal e_kj(t)) gives the windowed power P_kj(f) = |sum_t w_k(t) e_kj(t) exp(-i 2 pi f t)|^2 /
    (sum_t w_k^2 |H(f)|^4), the window w_k = |z_1| the target's envelope (matched to a mode that decays with the
    target) and |H|^4 the band-pass's power response (:func:`band_power`), so that for white sensor noise, coloured
    by the band-pass, P_kj(f) = sigma^2 X with X exponential of mean 1, independent over components and hits.
    The statistic is T(f) = sum_kj P_kj(f) / F: under that null T ~ Gamma(K, 1), K the number of components
    (hits times C - 1; the hits for one channel). F: several channels, sigma^2 as the median of every P_kj(f)
    over the searched frequencies over ln 2 (a line covers too few frequencies to move it); one channel, whose
    residual also holds the slow part's misfit (broad, smooth in frequency), the running median of sum_kj P_kj
    over ``FLOOR_BANDWIDTH`` times the mode frequency on each side of the target's own range, over the median of
    Gamma(K). Searched: where the band-pass passes ``HALF_POWER`` of the power or more, outside the target's own
    range (the instantaneous frequency of z_1 between the ``OWN_ENERGY`` and 1 - ``OWN_ENERGY`` quantiles of its
    energy, widened by twice the slow part's cut-off). T(f) is a smooth chi-square process in f: the largest T
    over a searched width B exceeds t with probability at most P(T > t) per searched interval plus Rice's expected
    upcrossings, B sqrt(lambda t / pi) g_K(t), g_K the Gamma(K) density and lambda = (2 pi)^2 Var_{w^2}(t) the
    window's second spectral moment (s^2); the threshold (:func:`floor_threshold`) sets that to ``FALSE_ALARM``,
    averaged over the error of F (ln F normal with the sample median's spread). The largest T above it is a
    second mode, at ``FALSE_ALARM`` per file; the stated rate holds for sensor noise white and independent per
    channel before the band-pass, its variances estimated from the data.
    Its frequency f, decay and size come from a least-squares fit over the hits (:func:`damped_mode`) of c_k
    (|z_1(t)| / |z_1(t_0)|)^p exp((-sigma + i 2 pi f)(t - t_0)) to each hit's residual along the mode's direction;
    its share is its displacement amplitude at the impact over the target's (the median over the hits). Not
    resolved: a mode inside the target's own range or where the band-pass takes it out; one of the target's own
    shape at the sensors (several channels: it is the target) or a mode the single channel's slow part follows;
    non-white or correlated sensor noise changes the null (the false-alarm rate is then not the stated one).
drift
    Non-stationarity: hits that reach the same amplitude at different times give different frequency or damping (a
    temperature drift across the hits, a joint that loosens while it rings within each hit). Each record's FreeVib
    estimates, less the backbone interpolated in ln a at their amplitudes (the backbone's own change across a bin,
    which would otherwise make the bin means depend on which samples fall in it), are averaged in the backbone's
    amplitude bins (the first and last bin of each record left out: partly covered, and where the end effects sit),
    and the bin means y_rb regressed on clocks c_rb, the mean clock of record r in bin b, with one level per bin:
    y_rb = y_b + sum_c rate_c c_rb; relative rates are per the backbone's mean. Within one hit amplitude and time
    are tied, so only hits that reach an amplitude at different times inform a rate, and the levels leave only those
    differences. Two clocks: the time since each hit's impact (s, from the record's first estimate: the same offset
    from the impact in every hit), which differs between hits of different strength (a drift within each hit; tested
    where it differs by a period or more at a fixed amplitude), and the hits' own time stamps where they differ (s),
    else the order of the hits (per hit) (a drift across hits). The bin means of a derivative are not independent:
    each is the change of the integrated quantity (the phase, ln A) across the bin over its duration, whose error at
    an edge amplitude a has variance proportional to 1 / a^2 (white sensor noise), so neighbouring bins of a record
    are anticorrelated and a record's errors do not average down with its samples; the fit is generalised least
    squares with that covariance, its scale the whitened chi^2 per degree of freedom. A rate is a finding when
    |rate| / its standard error exceeds Student's t at ``FALSE_ALARM`` (two-sided, shared by frequency and damping
    and by the clocks, each fitted alone). Where both clocks alone explain a drift they are fitted together, and the
    rates that stand are the findings; where neither stands (the hits' strengths follow their times: the data cannot
    tell the two clocks apart), the finding is the drift within each hit, naming the other clock and its rate. Needs
    three hits or more.
clipping, no_pretrigger, truncated_record
    The record itself: a channel that holds its extreme value for ``CLIPPED_SAMPLES`` consecutive samples or
    more (a saturated amplifier or converter); a channel whose first samples are already moving (mean |x - median|
    over ``PRETRIGGER_SAMPLES`` samples above ``PRETRIGGER_LEVEL`` of its peak and above ``PRETRIGGER_NOISE``
    times the noise at the record's end, :func:`record_end_noise`, so that a weak channel's noise is not taken
    for motion: the record starts after the impact); a band-passed channel whose envelope still falls at the record's end, beyond the scatter of a noise
    floor (:func:`still_decaying`: the record ends before the decay does).

Each finding is a JSON-ready dict: ``name``, ``outside_library`` (``FINDINGS``: whether no effect of a backbone
library can stand for it, so that the discrepancy loop's verdict cannot be "explained"), ``summary`` (one line)
and ``evidence`` (numbers). :func:`ringdown_findings` runs every check that applies and returns
``{"checked": [names], "found": [findings]}``, the record ``surrogacy freevib`` writes into the backbone CSV.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.ndimage
import scipy.signal
import scipy.stats
import scipy.optimize
from scipy.optimize import least_squares

from experiment.backbone import (ModeBackbone, RingDownBackbones, amplitude_bins, binned_means, record_statistics,
                                 values_at_grid)
from experiment.hilbert import analytic_signal, slow_part
from experiment.modal_filter import band_pass, dominant_shape
from experiment.ringdown import DISPLACEMENT_ORDER, RingDown

FALSE_ALARM = 1e-3
"""Probability that a check names a finding in a file that holds only what the backbone holds and noise."""

FINDINGS = {
    "second_mode": (True, "a second mode near the target beats with it"),
    "drift": (True, "frequency or damping drifts with time at a fixed amplitude"),
    "clipping": (True, "a channel is clipped: the largest amplitudes are wrong"),
    "no_pretrigger": (False, "the record starts after the impact: the largest amplitudes are missing"),
    "truncated_record": (False, "the record ends before the decay does: the smallest amplitudes are missing"),
    "flat_channel": (False, "a channel holds one value throughout (dead or disconnected): left out of the checks"),
}
"""Finding -> (outside any backbone library: the loop's verdict is "unexplained" with it; what it means)."""

TREND_BANDWIDTH = 0.01  # low-pass cut-off of the fitted mode's ln A and psi, fraction of the mode frequency
FLOOR_BANDWIDTH = 0.1  # width of the running median that is one channel's floor, fraction of the mode frequency
HALF_POWER = 0.5  # a second mode is searched where the band-pass passes this share of the power or more
OWN_ENERGY = 1e-3  # share of the target's energy left out of its own frequency range at each end
BLOCK_PERIODS = 10  # envelope blocks (median) for the noise floor and the end of the decay, periods
CLIPPED_SAMPLES = 3
PRETRIGGER_SAMPLES = 4
PRETRIGGER_LEVEL = 0.1
PRETRIGGER_NOISE = 4.0  # first samples' mean |x - median| over the record end's noise scale: no pre-trigger above
STILL_DECAYING = 0.1  # fall of ln(envelope) over the record's last eighth that still counts as a decay
FINAL_BLOCKS = 8


def finding(name: str, summary: str, evidence: dict) -> dict:
    """One finding as the JSON-ready record of the module docstring."""
    return {"name": name, "outside_library": FINDINGS[name][0], "summary": summary,
            "evidence": {key: value if isinstance(value, (str, list)) else float(value)
                         for key, value in evidence.items()}}


def block_medians(envelope: np.ndarray, block: int) -> np.ndarray:
    """Medians (n // block,) of consecutive blocks of an envelope."""
    n_blocks = envelope.size // block
    return np.median(envelope[:n_blocks * block].reshape(n_blocks, block), axis=1)


def decay_span(envelope: np.ndarray, block: int, noise_floor_factor: float = 3.0) -> tuple[int, int]:
    """[start, stop): from the envelope maximum to the end of the last block whose median is above
    ``noise_floor_factor`` times the last block's (the noise floor, where the record reaches it). Unlike
    ``experiment.hilbert.decay_end`` it does not stop where a beating envelope rises again."""
    start = int(np.argmax(envelope))
    medians = block_medians(envelope[start:], block)
    above = np.flatnonzero(medians > noise_floor_factor * medians[-1])
    return start, start + (int(above[-1]) + 1) * block if above.size else envelope.size


class TargetRemoved(NamedTuple):
    """One hit with the target mode removed (:func:`target_removed`), over its decay (:func:`decay_span`).

    channels: the C channels used (flat ones left out, :func:`flat_channels`); time: (m,) s; residual: (J, m)
    analytic signals of what is left: J = C - 1 components along ``basis``, orthogonal to the target's shape, or
    for one channel (J = 1) the channel less the target's slow part; target: (m,) analytic signal z_1 of the
    target's modal coordinate (for one channel its slow part), signal unit per unit of ``shape``; shape: (C,) the
    target's shape at the channels, 1 at its largest entry; basis: (C, J) the channels' amplitudes (signal unit)
    of a unit amplitude of each component; channel_residual: (C, m) each band-passed channel less the target's
    share in it; order: time derivatives between displacement and the signal
    (``experiment.ringdown.DISPLACEMENT_ORDER``)."""

    hit: str
    channels: tuple[str, ...]
    time: np.ndarray
    residual: np.ndarray
    target: np.ndarray
    shape: np.ndarray
    basis: np.ndarray
    channel_residual: np.ndarray
    order: int


def flat_channels(hit: RingDown) -> tuple[str, ...]:
    """Names of a hit's channels that hold one value throughout (a dead, disconnected or stuck sensor): no signal
    and no noise to check."""
    return tuple(name for name, raw in zip(hit.channels, hit.signals) if np.ptp(raw) == 0)


def band_power(frequency_hz: np.ndarray, sample_rate: float, band_hz) -> np.ndarray:
    """Power response (n,) at frequencies (n,) Hz of ``experiment.modal_filter.band_pass`` with its default order
    (Butterworth run forward and backward: |H(f)|^4), the colour it gives white sensor noise."""
    sections = scipy.signal.butter(4, band_hz, btype="bandpass", fs=sample_rate, output="sos")
    return np.abs(scipy.signal.sosfreqz(sections, worN=np.abs(frequency_hz), fs=sample_rate)[1]) ** 4


def target_removed(hit: RingDown, mode_frequency_hz: float, band_hz) -> TargetRemoved | None:
    """One hit's residual with the target removed (:class:`TargetRemoved`; None when every channel is flat).

    The band-passed channels y (C, n) hold the target in the shape s of their strongest component
    (``experiment.modal_filter.dominant_shape``), coordinate q = s^T y / s^T s. The residual is their projection
    on an orthonormal basis B (C, C - 1) of the complement of s, B^T y: the target is gone whatever its
    amplitude-dependent frequency and damping, a mode of another shape stays whatever its size. One channel: the
    target is the slow part of ln z (:func:`experiment.hilbert.slow_part`), which follows the stronger of two
    beating modes, and the residual is z - z_1. Over the decay of q, from its envelope maximum (the impact) to its
    noise floor."""
    flat = flat_channels(hit)
    live = [index for index, name in enumerate(hit.channels) if name not in flat]
    if not live:
        return None
    filtered = band_pass(hit.signals[live], hit.sample_rate, *band_hz)
    period = hit.sample_rate / mode_frequency_hz
    shape = dominant_shape(filtered) if len(live) > 1 else np.ones(1)
    modal = shape @ filtered / (shape @ shape)
    start, stop = decay_span(np.abs(scipy.signal.hilbert(modal)), int(BLOCK_PERIODS * period))
    target = analytic_signal(modal[start:stop], period)
    if len(live) == 1:
        target = slow_part(target, hit.sample_rate, TREND_BANDWIDTH * mode_frequency_hz)
        basis = np.ones((1, 1))
        residual = analytic_signal(filtered[0, start:stop], period)[None] - target
    else:
        basis = np.linalg.svd(shape[:, None])[0][:, 1:]
        residual = np.array([analytic_signal(row, period) for row in basis.T @ filtered[:, start:stop]])
    return TargetRemoved(hit.hit, tuple(hit.channels[index] for index in live), hit.time[start:stop], residual,
                         target, shape, basis, filtered[:, start:stop] - np.outer(shape, modal[start:stop]),
                         DISPLACEMENT_ORDER[hit.quantity])


def windowed_power(series: np.ndarray, window: np.ndarray, n_fft: int) -> np.ndarray:
    """|sum_t w_t x_t exp(-i 2 pi f t)|^2 / sum_t w_t^2 (J, n_fft) of series x (J, m) on the FFT grid of n_fft
    points, window w (m,): for white noise of variance s^2 its mean is s^2 at every frequency, and at frequencies
    away from 0 it is s^2 times an exponential variable of mean 1."""
    return np.abs(np.fft.fft(series * window, n_fft, axis=-1)) ** 2 / np.sum(window ** 2)


def search_grid(removed: list[TargetRemoved], mode_frequency_hz: float, band_hz, sample_rate: float):
    """The frequencies searched for a second mode: (frequency (n_fft,) Hz, the FFT grid four times finer than one
    over the longest decay; searched (n_fft,) bool; colour (n_fft,), :func:`band_power`; own (2,) Hz).

    Searched: inside the band where the band-pass passes ``HALF_POWER`` of the power or more, outside the
    target's own range ``own``: the instantaneous frequency of z_1 between the ``OWN_ENERGY`` and 1 -
    ``OWN_ENERGY`` quantiles of its energy |z_1|^2 over all hits, widened by twice the slow part's cut-off."""
    n_fft = 4 * 2 ** int(np.ceil(np.log2(max(entry.time.size for entry in removed))))
    frequency = np.fft.fftfreq(n_fft, 1 / sample_rate)
    colour = band_power(frequency, sample_rate, band_hz)
    instantaneous = np.concatenate([np.gradient(np.unwrap(np.angle(entry.target)), 1 / sample_rate) / (2 * np.pi)
                                    for entry in removed])
    energy = np.concatenate([np.abs(entry.target) ** 2 for entry in removed])
    order = np.argsort(instantaneous)
    quantile = np.cumsum(energy[order]) / np.sum(energy)
    cutoff = TREND_BANDWIDTH * mode_frequency_hz
    own = (instantaneous[order][np.searchsorted(quantile, OWN_ENERGY)] - 2 * cutoff,
           instantaneous[order][min(np.searchsorted(quantile, 1 - OWN_ENERGY), order.size - 1)] + 2 * cutoff)
    searched = ((frequency > band_hz[0]) & (frequency < band_hz[1]) & (colour >= HALF_POWER)
                & ((frequency < own[0]) | (frequency > own[1])))
    return frequency, searched, colour, own


def channel_noise(removed: list[TargetRemoved], frequency: np.ndarray, searched: np.ndarray, colour: np.ndarray
                  ) -> dict[str, float]:
    """Noise variance (signal unit^2 per unit of :func:`windowed_power`) of each channel name, pooled over the
    hits: the median over the searched frequencies of its residual's :func:`windowed_power`, divided by the
    band-pass colour, by ln 2 (the median of an exponential variable over its mean) and by 1 - s_c^2 / s^T s
    (the share of a channel's own noise that the target's removal leaves, where the channels' noises are alike).
    A second mode's line covers too few frequencies to move the median."""
    pooled = {}
    for entry in removed:
        kept = 1 - entry.shape ** 2 / (entry.shape @ entry.shape)
        power = windowed_power(entry.channel_residual, np.abs(entry.target), frequency.size)
        for name, row, share in zip(entry.channels, power, kept):
            pooled.setdefault(name, []).append(row[searched] / colour[searched] / share)
    return {name: float(np.median(rows) / np.log(2)) for name, rows in pooled.items()}


def whitened(entry: TargetRemoved, noise: dict[str, float]) -> TargetRemoved:
    """The hit's residual components made independent and of equal noise: with Sigma the channels' noise
    variances (``noise``, :func:`channel_noise`), the components B^T y have noise covariance C = B^T Sigma B = R
    R^T (R = V Lambda^(1/2) from its eigenvectors V and eigenvalues Lambda); the residual becomes R^-1 B^T y and
    the basis B R, so that the basis times a component amplitude is still the channels' amplitudes."""
    covariance = entry.basis.T @ (np.array([noise[name] for name in entry.channels])[:, None] * entry.basis)
    values, vectors = np.linalg.eigh(covariance)
    root = vectors * np.sqrt(values)
    return entry._replace(residual=np.linalg.solve(root, entry.residual), basis=entry.basis @ root)


def floor_threshold(degrees: int, searched_hz: float, segments: int, spectral_moment: float, floor_count: float,
                    floor_degrees: int, false_alarm: float) -> tuple[float, float]:
    """Threshold t on T / F (module docstring) at ``false_alarm`` per file, and the relative standard error of F.

    T(f) ~ Gamma(``degrees``) at each frequency, a smooth process over the ``segments`` searched intervals of
    ``searched_hz`` Hz in all: the largest T exceeds t with probability at most segments P(T > t) plus the
    expected number of upcrossings of t (Rice's formula for a chi-square process: T = sum |X_j|^2, each X_j a
    complex Gaussian process in f whose derivative has variance lambda = ``spectral_moment`` s^2 per unit
    variance, so T' given T = t is normal with variance 2 lambda t and the upcrossings per Hz are
    sqrt(lambda t / pi) g(t), g the Gamma density). F is the median of ``floor_count`` independent
    Gamma(``floor_degrees``) values scaled to the mean: ln F is normal with standard deviation 1 / (2 sqrt(n) g(m)
    m) (m the median), which the threshold averages over (Gauss-Hermite)."""
    median = scipy.stats.gamma.median(floor_degrees)
    spread = 1 / (2 * np.sqrt(floor_count) * scipy.stats.gamma.pdf(median, floor_degrees) * median)
    nodes, weights = np.polynomial.hermite_e.hermegauss(21)
    weights = weights / np.sum(weights)

    def excess(threshold):
        level = threshold * np.exp(spread * nodes)
        crossings = (segments * scipy.stats.gamma.sf(level, degrees) + searched_hz
                     * np.sqrt(spectral_moment * level / np.pi) * scipy.stats.gamma.pdf(level, degrees))
        return np.log(np.sum(weights * crossings)) - np.log(false_alarm)

    upper = scipy.stats.gamma.isf(false_alarm / (1 + searched_hz * np.sqrt(spectral_moment)), degrees)
    while excess(upper) > 0:
        upper *= 1.5
    return scipy.optimize.brentq(excess, scipy.stats.gamma.mean(degrees), upper), spread


def damped_mode(removed: list[TargetRemoved], frequency_hz: float, bounds_hz, sample_rate: float):
    """Least-squares fit of the found mode in every hit: each hit's residual projected on its direction at
    ``frequency_hz`` (the components' windowed Fourier coefficients there, normalised), v_k(t), fitted with
    c_k (|z_1(t)| / |z_1(t_0)|)^p exp((-sigma + i 2 pi f)(t - t_0)), f, sigma and p shared by the hits (p = 1,
    sigma = 0: the target's decay; p = 0: a linear mode), c_k solved linearly, every ``sample_rate`` / (4 f) th
    sample. Returns (f Hz, sigma 1/s, p, shares (n_hits,), decay rates (n_hits,) 1/s). A share is the mode's
    displacement amplitude at the impact over the target's: |c_k| times the direction's norm in the channels' unit
    over the target's, |s| |z_1(t_0)|, times (f_1 / f)^order, f_1 the target's frequency over the first
    ``BLOCK_PERIODS`` periods (a velocity or acceleration amplitude is omega^order times the displacement's). A
    decay rate is the energy-weighted mean of -d ln|g| / dt over the hit."""
    step = max(1, int(sample_rate / (4 * frequency_hz)))
    series, logs, times, sizes, impact_hz = [], [], [], [], []
    for entry in removed:
        window = np.abs(entry.target)
        elapsed = entry.time - entry.time[0]
        first = np.unwrap(np.angle(entry.target[:int(BLOCK_PERIODS * sample_rate / frequency_hz)]))
        impact_hz.append((np.median(np.gradient(first, 1 / sample_rate)) / (2 * np.pi)) ** entry.order)
        at_peak = (entry.residual * window) @ np.exp(-2j * np.pi * frequency_hz * elapsed)
        direction = at_peak / np.linalg.norm(at_peak)
        series.append((direction.conj() @ entry.residual)[::step])
        logs.append(np.log(window / window[0])[::step])
        times.append(elapsed[::step])
        sizes.append(np.linalg.norm(entry.basis @ direction) / (np.linalg.norm(entry.shape) * window[0]))

    def bases(parameters):
        return [np.exp(parameters[2] * log + (-parameters[1] + 2j * np.pi * parameters[0]) * elapsed)
                for log, elapsed in zip(logs, times)]

    def amplitudes(parameters):
        return [np.vdot(basis, values) / np.vdot(basis, basis).real for values, basis in zip(series, bases(parameters))]

    def misfit(parameters):
        difference = np.concatenate([values - amplitude * basis for values, basis, amplitude
                                     in zip(series, bases(parameters), amplitudes(parameters))])
        return np.concatenate([difference.real, difference.imag])

    fit = least_squares(misfit, [frequency_hz, 0.0, 1.0], bounds=([bounds_hz[0], -np.inf, 0.0], [bounds_hz[1], np.inf,
                        2.0]), x_scale=[0.1, 1.0, 0.1])
    decay = [np.sum(np.abs(basis) ** 2 * -np.gradient(np.log(np.abs(basis)), elapsed)) / np.sum(np.abs(basis) ** 2)
             for basis, elapsed in zip(bases(fit.x), times)]
    orders = np.array([entry.order for entry in removed])
    return (*fit.x, np.abs(amplitudes(fit.x)) * np.array(sizes) * np.array(impact_hz) / fit.x[0] ** orders,
            np.array(decay))


def second_mode_statistic(removed: list[TargetRemoved], mode_frequency_hz: float, band_hz, sample_rate: float,
                          pooled_floor: bool) -> dict:
    """T(f) / F over the searched frequencies (module docstring) with what its null distribution needs:
    ``frequency_hz`` (n,) Hz and ``statistic`` (n,), Gamma(``degrees``) under the null; ``searched_hz``, their
    width, and ``segments``, the intervals they make; ``spectral_moment`` (s^2), lambda = (2 pi)^2 times the
    variance of time under the weight w^2, the window's (averaged over the components); ``floor_count`` and
    ``floor_degrees``, the independent values of F's median (the searched width over the equivalent noise bandwidth
    f_s sum w^2 / (sum w)^2 of the sharpest window, or of the widest for a running median) and their Gamma degrees
    (:func:`floor_threshold`). pooled_floor: F is one level over the band (the residuals are
    white noise after the band-pass colour: several channels); else a running median of T over
    ``FLOOR_BANDWIDTH`` times the mode frequency on each side of the target's own range (one channel, whose
    residual holds the slow part's misfit beside noise)."""
    frequency, searched, colour, own = search_grid(removed, mode_frequency_hz, band_hz, sample_rate)
    windows = [np.abs(entry.target) for entry in removed]
    power = np.concatenate([windowed_power(entry.residual, window, frequency.size)[:, searched] / colour[searched]
                            for entry, window in zip(removed, windows)])
    degrees, total = power.shape[0], np.sum(power, axis=0)
    bin_hz = sample_rate / frequency.size
    resolution_hz = [sample_rate * np.sum(window ** 2) / np.sum(window) ** 2 for window in windows]  # ENBW, Hz
    independent = np.count_nonzero(searched) * bin_hz / min(resolution_hz)
    moments = [(2 * np.pi) ** 2 * (np.average(entry.time ** 2, weights=window ** 2)
                                   - np.average(entry.time, weights=window ** 2) ** 2)
               for entry, window in zip(removed, windows)]
    spectral_moment = np.average(moments, weights=[entry.residual.shape[0] for entry in removed])
    if pooled_floor:
        floor = np.full(total.size, np.median(power) / np.log(2))
        floor_count, floor_degrees = power.shape[0] * independent, 1
    else:
        width = int(FLOOR_BANDWIDTH * mode_frequency_hz / bin_hz)
        below = frequency[searched] < own[0]
        floor = np.empty(total.size)
        for side in (below, ~below):
            if np.any(side):
                floor[side] = scipy.ndimage.median_filter(total[side], size=width, mode="nearest")
        floor = floor / scipy.stats.gamma.median(degrees)
        floor_count, floor_degrees = FLOOR_BANDWIDTH * mode_frequency_hz / max(resolution_hz), degrees
    return {"frequency_hz": frequency[searched], "statistic": total / floor, "degrees": degrees,
            "searched_hz": np.count_nonzero(searched) * bin_hz,
            "segments": 1 + int(np.any(np.diff(frequency[searched] < own[0]))),
            "spectral_moment": spectral_moment, "floor_count": floor_count, "floor_degrees": floor_degrees}


def second_mode(removed: list[TargetRemoved], mode_frequency_hz: float, band_hz, sample_rate: float,
                false_alarm: float, pooled_floor: bool) -> dict | None:
    """The second mode in the hits' residuals (module docstring) as a dict of evidence, or None when the largest
    T / F over the searched frequencies (:func:`second_mode_statistic`) is below its threshold at ``false_alarm``
    per file (:func:`floor_threshold`); the mode's frequency, decay and share from :func:`damped_mode`, the
    target's frequency the median over the decay of the instantaneous frequency of z_1's slow part (at low
    amplitude most of the time: the ratio is to about the linear frequency)."""
    tested = second_mode_statistic(removed, mode_frequency_hz, band_hz, sample_rate, pooled_floor)
    statistic, searched_hz = tested["statistic"], tested["frequency_hz"]
    threshold, spread = floor_threshold(tested["degrees"], tested["searched_hz"], tested["segments"],
                                        tested["spectral_moment"], tested["floor_count"], tested["floor_degrees"],
                                        false_alarm)
    peak = int(np.argmax(statistic))
    if statistic[peak] <= threshold:
        return None
    found_hz, decay_rate, exponent, shares, decay = damped_mode(removed, searched_hz[peak],
                                                                (searched_hz[0], searched_hz[-1]), sample_rate)
    cutoff = TREND_BANDWIDTH * mode_frequency_hz
    target_hz = np.median(np.concatenate([np.gradient(np.unwrap(np.angle(slow_part(entry.target, sample_rate, cutoff))),
                                                      1 / sample_rate) for entry in removed])) / (2 * np.pi)
    return {"frequency_hz": found_hz, "target_frequency_hz": target_hz,
            "relative_amplitude": float(np.median(shares)), "amplitude_spread": float(np.std(shares)),
            "damping_ratio": float(np.median(decay)) / (2 * np.pi * found_hz), "envelope_exponent": exponent,
            "extra_decay_rate_per_s": decay_rate, "statistic": statistic[peak], "threshold": threshold,
            "degrees_of_freedom": tested["degrees"], "searched_hz": tested["searched_hz"],
            "spectral_moment_s2": tested["spectral_moment"], "floor_spread": spread,
            "floor": "one level over the band" if pooled_floor else "running median"}


def hit_residuals(hits: list[RingDown], mode_frequency_hz: float, band_hz) -> tuple[list[TargetRemoved], bool]:
    """Every hit's residual with the target removed (:func:`target_removed`; hits whose channels are all flat
    left out) and whether every hit has several channels, whose residual components are then made independent
    and of equal noise (:func:`whitened`, with each channel's noise from :func:`channel_noise`)."""
    removed = [entry for entry in (target_removed(hit, mode_frequency_hz, band_hz) for hit in hits) if entry]
    several = bool(removed) and min(len(entry.channels) for entry in removed) > 1
    if several:
        noise = channel_noise(removed, *search_grid(removed, mode_frequency_hz, band_hz, hits[0].sample_rate)[:3])
        removed = [whitened(entry, noise) for entry in removed]
    return removed, several


def second_mode_findings(hits: list[RingDown], mode_frequency_hz: float, band_hz) -> list[dict]:
    """:func:`second_mode` on the hits' residuals (:func:`hit_residuals`) at ``FALSE_ALARM`` per file; one finding
    with the second mode's frequency and amplitude share (empty if none). Flat channels are left out and named in
    the evidence."""
    removed, several = hit_residuals(hits, mode_frequency_hz, band_hz)
    if not removed:
        return []
    evidence = second_mode(removed, mode_frequency_hz, band_hz, hits[0].sample_rate, FALSE_ALARM, several)
    if evidence is None:
        return []
    frequency, target, share = evidence["frequency_hz"], evidence["target_frequency_hz"], evidence["relative_amplitude"]
    left_out = sorted({f"{hit.hit}: {name}" for hit in hits for name in flat_channels(hit)})
    checked = sum(len(entry.channels) for entry in removed)
    return [finding("second_mode", f"a second mode at {frequency:.4g} Hz ({100 * (frequency / target - 1):+.2f} % of "
                    f"the target's {target:.4g} Hz) with {100 * share:.3g} % of its amplitude at the impact, seen "
                    f"together in {checked} channel(s) of {len(removed)} hit(s)",
                    {**evidence, "frequency_ratio": frequency / target, "channels_checked": checked,
                     "hits_checked": len(removed), "channels_left_out": left_out})]


def hit_of(label: str) -> str:
    """The hit of a record's label ``<hit>: <channel or modal>`` (``experiment.backbone.mode_signals``)."""
    return label.rsplit(": ", 1)[0]


def bin_durations(amplitude: np.ndarray, time: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Time (n_grid,) s that a record's estimates at ``amplitude`` (n,) sampled at ``time`` (n,) s spend in each
    grid bin: their count times the sampling step."""
    index = np.digitize(amplitude, amplitude_bins(grid)) - 1
    inside = (index >= 0) & (index < grid.size)
    return np.bincount(index[inside], minlength=grid.size) * (time[1] - time[0])


def derivative_covariance(bins: np.ndarray, durations: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Covariance (m, m), up to one scale, of one record's bin means of a time derivative (FreeVib's frequency,
    d psi / dt, and damping, from d ln A / dt) in the grid bins ``bins`` (m,) that it covers for ``durations``
    (m,) s. The mean of a derivative over a bin is the change of its integral Psi between the bin's edges over the
    bin's duration, (Psi(edge b) - Psi(edge b + 1)) / duration_b; white sensor noise puts an error of variance
    proportional to 1 / a^2 into Psi where the record crosses the edge amplitude a (``edges``, (n_grid + 1,)).
    Bins that share an edge are anticorrelated: a record's bin means are not independent, and the scatter of its
    samples within a bin (:func:`~experiment.backbone.binned_standard_error`) does not measure their error."""
    difference = np.zeros((bins.size, edges.size))
    difference[np.arange(bins.size), bins] = 1 / durations
    difference[np.arange(bins.size), bins + 1] = -1 / durations
    return (difference / edges) @ (difference / edges).T


def level_regression(values: np.ndarray, clocks: list[np.ndarray], durations: np.ndarray, used: np.ndarray,
                     edges: np.ndarray):
    """Generalised least squares of bin means on clocks with one level per amplitude bin, y_rb = y_b + sum_c
    rate_c clock_c,rb, each record's errors correlated as :func:`derivative_covariance` says.

    values: (n_records, n_grid) bin means; clocks: p arrays (n_records, n_grid), each record's clock in each bin
    (s, or hits); durations: (n_records, n_grid) s in each bin; used: (n_records, n_grid) bool, the bins
    compared (two records or more in each); edges: (n_grid + 1,) bin edges (amplitude). The covariance's unknown
    scale is the whitened residuals' chi^2 per degree of freedom. Returns rates (p,) (unit of values per clock
    unit), their standard errors (p,) and the degrees of freedom (records' bins less levels less p)."""
    levels = np.flatnonzero(used.any(axis=0))
    design, whitened = [], []
    for record in range(values.shape[0]):
        bins = np.flatnonzero(used[record])
        if bins.size == 0:
            continue
        columns = np.zeros((bins.size, levels.size + len(clocks)))
        columns[np.arange(bins.size), np.searchsorted(levels, bins)] = 1.0
        for number, clock in enumerate(clocks):
            columns[:, levels.size + number] = clock[record, bins]
        factor = np.linalg.cholesky(derivative_covariance(bins, durations[record, bins], edges))
        design.append(scipy.linalg.solve_triangular(factor, columns, lower=True))
        whitened.append(scipy.linalg.solve_triangular(factor, values[record, bins], lower=True))
    design, whitened = np.vstack(design), np.concatenate(whitened)
    dof = design.shape[0] - design.shape[1]
    solution, *_ = np.linalg.lstsq(design, whitened, rcond=None)
    residual = whitened - design @ solution
    covariance = residual @ residual / max(dof, 1) * np.linalg.pinv(design.T @ design)
    return solution[levels.size:], np.sqrt(np.diag(covariance)[levels.size:]), dof


def drift_findings(hits: list[RingDown], measured: RingDownBackbones, false_alarm: float = FALSE_ALARM
                   ) -> list[dict]:
    """Non-stationarity (module docstring): frequency and damping at fixed amplitude regressed on the time since
    each hit's impact (a drift within each hit) and on the hits' clock (a drift across hits), one level per
    amplitude bin (:func:`level_regression`); a finding per quantity and clock whose rate exceeds its noise at
    ``false_alarm`` (shared by every test made; empty if none)."""
    grid = measured.hilbert.amplitude
    starts = {hit.hit: hit.time[0] for hit in hits}
    stamped = len(set(starts.values())) == len(starts)
    order = {hit.hit: number for number, hit in enumerate(hits)}
    since, across, durations = [], [], []
    for record in measured.records:
        estimate = record.hilbert
        clock = binned_means(estimate.amplitude, estimate.time - estimate.time[0], grid)
        filled = np.flatnonzero(np.isfinite(clock))
        clock[filled[[0, -1]] if filled.size else []] = np.nan  # partly covered bins, where end effects sit
        since.append(clock)
        across.append(binned_means(estimate.amplitude, estimate.time, grid) if stamped
                      else np.full(grid.size, float(order[hit_of(record.label)])))
        durations.append(bin_durations(estimate.amplitude, estimate.time, grid))
    used = np.isfinite(np.array(since))
    used[:, np.count_nonzero(used, axis=0) < 2] = False  # a level needs two records to compare
    if np.count_nonzero(used) == 0:
        return []
    since, across, durations = (np.nan_to_num(np.array(values)) for values in (since, across, durations))
    centred = since - np.sum(since * used, axis=0) / np.maximum(np.sum(used, axis=0), 1)
    clocks = {"across": across}
    if np.sqrt(np.mean(centred[used] ** 2)) > 1 / measured.mode_frequency_hz:
        clocks["within"] = since  # the hits reach an amplitude at times since their impact a period or more apart
    said = {"within": ("time since each hit's impact", "s", max(hit.time[-1] - hit.time[0] for hit in hits),
                       "of a hit"),
            "across": ("time stamps of the hits", "s", max(hit.time[-1] for hit in hits) - min(starts.values()),
                       "of the hits") if stamped else ("order of the hits", "hit", len(hits) - 1, "of the hits")}
    found = []
    for name in ("natural_frequency_hz", "damping_ratio"):
        backbone = getattr(measured.hilbert, name)
        known = np.isfinite(backbone)
        values = np.nan_to_num(np.array([binned_means(  # the backbone's own change across a bin taken out first
            record.hilbert.amplitude, getattr(record.hilbert, name) - np.interp(
                np.log(record.hilbert.amplitude), np.log(grid[known]), backbone[known]), grid)
            for record in measured.records]))

        def fitted(names):
            """{clock: (rate, standard error, critical t)} of the clocks ``names`` fitted together."""
            rates, errors, dof = level_regression(values, [clocks[clock] for clock in names], durations, used,
                                                  amplitude_bins(grid))
            critical = scipy.stats.t.isf(false_alarm / (4 * len(clocks)), dof) if dof >= 2 else np.inf
            return {clock: (rate, error, critical) for clock, rate, error in zip(names, rates, errors)}

        def beyond(fits):
            return {clock: fit for clock, fit in fits.items() if abs(fit[0]) > fit[2] * fit[1] > 0}

        alone = {clock: fitted([clock])[clock] for clock in clocks}
        significant, confounded = beyond(alone), False
        if len(significant) == 2:  # each clock alone explains the drift: fitted together, where the hits' strengths
            together = beyond(fitted(list(clocks)))  # and times tell them apart, neither stands for the other
            confounded = not together
            significant = {"within": significant["within"]} if confounded else together
        level = float(np.mean(backbone[used.any(axis=0)]))
        label = "frequency" if name == "natural_frequency_hz" else "damping"
        for clock, (rate, error, critical) in significant.items():
            clock_name, unit, span, of = said[clock]
            evidence = {"quantity": name, f"rate_per_{unit}": rate, f"relative_rate_per_{unit}": rate / level,
                        "relative_change_over_span": rate * span / level, f"span_{unit}": span,
                        "standard_error": error, "t": rate / error, "critical_t": critical, "clock": clock_name}
            summary = (f"the {label} {'rises' if rate > 0 else 'falls'} by {abs(rate / level):.3g} of itself per "
                       f"{unit} of the {clock_name} at fixed amplitude ({abs(rate * span / level):.3g} over the "
                       f"{span:.4g} {unit} {of})")
            if clock == "within":  # what the backbone's average holds of it: the correction's lever
                evidence |= {"amplitude": grid.tolist(), "time_since_impact_s": [
                    None if np.isnan(value) else float(value) for value in backbone_times(measured, grid)]}
            if confounded:  # the hits' strengths follow their order: the data cannot tell the two clocks apart
                other = alone["across"][0] * said["across"][2] / level
                evidence |= {"confounded_with": said["across"][0], "confounded_relative_change_over_span": other}
                summary += (f", or by {other:+.3g} over the {said['across'][0]}: the hits' strengths follow their "
                            "times, and the data cannot tell the two apart")
            found.append(finding("drift", summary, evidence))
    return found


STANDARD_ERRORS = {"natural_frequency_hz": "natural_frequency_standard_error_hz",
                   "damping_ratio": "damping_ratio_standard_error"}
"""A backbone quantity -> the field of its standard error (``experiment.backbone.Backbone``)."""


def backbone_times(measured: RingDownBackbones, grid: np.ndarray) -> np.ndarray:
    """Mean over the records of the time since each record's impact (s; its ``onset``, else its first estimate) at
    each grid amplitude (n_grid,), averaged as the Hilbert backbone averages the frequency and damping
    (``experiment.backbone.values_at_grid``, ``record_statistics``): a drift within each hit of rate r moves the
    backbone's value there by r times it."""
    estimates = [record.hilbert for record in measured.records]
    times = values_at_grid([estimate.amplitude for estimate in estimates],
                           [estimate.time - (estimate.time[0] if estimate.onset is None else estimate.onset)
                            for estimate in estimates], grid)
    return record_statistics(times)[0]


def drift_corrected(mode: ModeBackbone) -> tuple[ModeBackbone, dict]:
    """The backbone ``mode`` less the drift within each hit its signal checks found (``drift_findings``, clock
    "time since each hit's impact"): each quantity y at amplitude a becomes y - r t(a), the backbone as at each
    hit's impact, with r the finding's rate and t(a) the mean time since impact behind the point
    (:func:`backbone_times`, interpolated in ln a, held at its ends beyond them); the point's standard error in
    quadrature with r's times t(a). The spread over the hits is left as it was (it still holds the drift's part,
    the hits reaching a point at different times: the loop's weight, the larger of the standard error and the
    spread over the square root of the hits, stays conservative there), and r's error, one for every point, is
    counted at each as if its own. Where the finding cannot tell the drift within each hit from one over the order
    of the hits (``confounded_with``), it names the drift within each hit, and that is what is taken out.
    Returns (the corrected backbone, {quantity: {"rate_per_s", "standard_error", "largest_shift"} and
    "confounded_with" where the finding names it}); the backbone itself and {} where no such drift was found, or
    where its times are absent (a drift across the hits is not corrected: its reference time, the one the nominal
    holds, is unknown)."""
    corrections, backbone = {}, mode.backbone
    for entry in mode.findings.get("found", []):
        evidence = entry.get("evidence", {})
        known = [(a, t) for a, t in zip(evidence.get("amplitude", []), evidence.get("time_since_impact_s", []))
                 if t is not None]
        if entry["name"] != "drift" or not known:
            continue
        quantity = evidence["quantity"]
        amplitude, time = np.array(known).T
        since = np.interp(np.log(backbone.amplitude), np.log(amplitude), time)
        shift, error = evidence["rate_per_s"] * since, STANDARD_ERRORS[quantity]
        backbone = replace(backbone, **{quantity: getattr(backbone, quantity) - shift,
                                        error: np.hypot(getattr(backbone, error), evidence["standard_error"] * since)})
        corrections[quantity] = {"rate_per_s": evidence["rate_per_s"], "standard_error": evidence["standard_error"],
                                 "largest_shift": float(np.max(np.abs(shift)))} | (
            {"confounded_with": evidence["confounded_with"]} if "confounded_with" in evidence else {})
    return replace(mode, backbone=backbone), corrections


def still_decaying(medians: np.ndarray, false_alarm: float) -> bool:
    """Whether an envelope's block medians (n,) still fall at the record's end: over its last eighth (at least
    ``FINAL_BLOCKS`` blocks) ln(median) falls by more than ``STILL_DECAYING`` (relative) along a straight line
    whose slope is below zero by more than Student's t at ``false_alarm`` (one-sided) times its standard error. At
    the noise floor the medians scatter about a constant."""
    final = np.log(medians[-max(FINAL_BLOCKS, medians.size // 8):])
    if medians.size < FINAL_BLOCKS:
        return False
    fit = scipy.stats.linregress(np.arange(final.size), final)
    drop = -fit.slope * (final.size - 1)
    return drop > STILL_DECAYING and -fit.slope > scipy.stats.t.isf(false_alarm, final.size - 2) * fit.stderr


def record_end_noise(raw: np.ndarray, block: int) -> float:
    """Standard deviation of a raw channel (n,) over its last ``block`` samples, 1.4826 times their median absolute
    deviation: the noise where the decay has reached it, an upper bound of the noise where it has not."""
    end = raw[-block:]
    return float(1.4826 * np.median(np.abs(end - np.median(end))))


def record_findings(hits: list[RingDown], mode_frequency_hz: float, band_hz) -> list[dict]:
    """Clipping, no pre-trigger and a truncated record (module docstring), one finding each with the channels
    where they are seen and a level per channel: the clipped value (signal unit), the first samples' mean
    |x - median| relative to the peak, the envelope where the record ends relative to its peak (dB); empty if
    none. A flat channel (:func:`flat_channels`) is none of these: it is named in a ``flat_channel`` finding (a
    caveat, its level the value it holds) and left out of the other checks."""
    seen = {name: [] for name in ("clipping", "no_pretrigger", "truncated_record", "flat_channel")}
    n_channels = sum(len(hit.channels) - len(flat_channels(hit)) for hit in hits)
    levels = {name: [] for name in seen}
    for hit in hits:
        block = int(BLOCK_PERIODS * hit.sample_rate / mode_frequency_hz)
        filtered = band_pass(hit.signals, hit.sample_rate, *band_hz)
        flat = flat_channels(hit)
        for name, raw, signal in zip(hit.channels, hit.signals, filtered):
            label = f"{hit.hit}: {name}"
            if name in flat:
                seen["flat_channel"].append(label)
                levels["flat_channel"].append(raw[0])
                continue
            peak = np.max(np.abs(raw))
            at_extreme = np.isclose(np.abs(raw), peak, rtol=1e-9, atol=0.0)
            runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], at_extreme.astype(int), [0]]))))[::2]
            if runs.max() >= CLIPPED_SAMPLES:
                seen["clipping"].append(label)
                levels["clipping"].append(peak)
            start = np.mean(np.abs(raw[:PRETRIGGER_SAMPLES] - np.median(raw)))
            moving = start / np.max(np.abs(raw - np.median(raw)))
            if moving > PRETRIGGER_LEVEL and start > PRETRIGGER_NOISE * record_end_noise(raw, block):
                seen["no_pretrigger"].append(label)
                levels["no_pretrigger"].append(moving)
            envelope = np.abs(scipy.signal.hilbert(signal))
            medians = block_medians(envelope[int(np.argmax(envelope)):], block)
            if still_decaying(medians, FALSE_ALARM / n_channels):
                seen["truncated_record"].append(label)
                levels["truncated_record"].append(20 * np.log10(medians[-1] / medians[0]))
    summaries = {
        "clipping": lambda: f"held at its extreme for {CLIPPED_SAMPLES} samples or more in {len(seen['clipping'])} "
                            f"channel(s), at {min(levels['clipping']):.4g} (signal unit) and above",
        "no_pretrigger": lambda: f"{len(seen['no_pretrigger'])} channel(s) already move at the first sample (up to "
                                 f"{100 * max(levels['no_pretrigger']):.3g} % of their peak)",
        "truncated_record": lambda: f"{len(seen['truncated_record'])} channel(s) still decaying where the record "
                                    f"ends, their envelope there {-max(levels['truncated_record']):.3g} dB below its "
                                    "peak or less",
        "flat_channel": lambda: f"{len(seen['flat_channel'])} channel(s) hold one value throughout, left out of the "
                                "checks",
    }
    return [finding(name, summaries[name](), {"channels": channels, "levels": [float(v) for v in levels[name]]})
            for name, channels in seen.items() if channels]


def ringdown_findings(hits: list[RingDown], measured: RingDownBackbones, band_hz) -> dict:
    """Every check that applies to the hits and their backbone (module docstring): ``{"checked": [...],
    "found": [...]}``; drift is checked with three hits or more."""
    checked = ["second_mode", "clipping", "no_pretrigger", "truncated_record", "flat_channel"]
    found = (second_mode_findings(hits, measured.mode_frequency_hz, band_hz)
             + record_findings(hits, measured.mode_frequency_hz, band_hz))
    if len(hits) >= 3:
        checked.append("drift")
        found += drift_findings(hits, measured)
    return {"checked": checked, "found": found}
