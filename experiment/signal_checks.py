"""What a backbone hides: checks of a ring-down's signals beside its backbone, each a named finding with evidence.

A backbone holds one mode's natural frequency and damping against amplitude. Three things pass through it unseen
and are checked on the signals instead (docs/design.md section 6):

second_mode
    A second mode in the band of the target, beating with it (a modal filter may project it out of the backbone).
    In each band-passed channel of each hit, the fitted mode is removed: the analytic signal z = A e^(i psi) over
    the decay (from the envelope maximum to the noise floor) is written ln z = ln A + i psi, whose slow part (a
    zero-phase low-pass at ``TREND_BANDWIDTH`` times the mode frequency) is the target mode z_1. The residual
    e = z - z_1 holds the rest: white sensor noise and any other mode. Its periodogram |E(f)|^2, outside the
    target's own frequencies (its instantaneous frequency range widened by twice the low-pass cut-off), is divided
    by its running median (the local noise floor; for noise the ratio to the mean is exponentially distributed).
    A peak above ln(M / alpha) times the mean floor, M the independent frequencies searched and alpha the record's
    share of ``FALSE_ALARM``, is a second mode; a damped sinusoid c exp((-sigma + i 2 pi f)(t - t_0)) fitted to
    e by least squares gives its frequency f and its amplitude |c| relative to |z_1| at the envelope maximum
    t_0 (the impact). Not resolved: a second mode within the target's own frequency range (closer than twice the
    low-pass cut-off to it); nor one that the band-pass takes out.
drift
    Non-stationarity: hits that reach the same amplitude at different times give different frequency or damping
    (a temperature drift, a loosening joint). Each record's FreeVib estimates are averaged in the backbone's
    amplitude bins (the first and last bin of each record left out: partly covered, and where the end effects
    sit), and the bin means y_rb regressed on the time t_rb at which record r was in bin b, with one level per
    bin: y_rb = y_b + rate t_rb. The clock is the hits' own time stamps where they differ (s), else the order of
    the hits (per hit). The rate is a finding when |rate| / its standard error exceeds Student's t at
    ``FALSE_ALARM`` (two-sided, shared by frequency and damping). Needs three hits or more.
clipping, no_pretrigger, truncated_record
    The record itself: a channel that holds its extreme value for ``CLIPPED_SAMPLES`` consecutive samples or
    more (a saturated amplifier or converter); a channel whose first samples are already moving (mean |x - median|
    over ``PRETRIGGER_SAMPLES`` samples above ``PRETRIGGER_LEVEL`` of its peak: the record starts after the
    impact); a band-passed channel whose envelope still falls at the record's end, beyond the scatter of a noise
    floor (:func:`still_decaying`: the record ends before the decay does).

Each finding is a JSON-ready dict: ``name``, ``outside_library`` (``FINDINGS``: whether no effect of a backbone
library can stand for it, so that the discrepancy loop's verdict cannot be "explained"), ``summary`` (one line)
and ``evidence`` (numbers). :func:`ringdown_findings` runs every check that applies and returns
``{"checked": [names], "found": [findings]}``, the record ``surrogacy freevib`` writes into the backbone CSV.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage
import scipy.signal
import scipy.stats
from scipy.optimize import least_squares

from experiment.backbone import MeasuredBackbone, binned_means, binned_standard_error
from experiment.hilbert import analytic_signal, slow_part
from experiment.modal_filter import band_pass, dominant_shape, modal_coordinates
from experiment.ringdown import RingDown

FALSE_ALARM = 1e-3
"""Probability that a check names a finding in a file that holds only what the backbone holds and noise."""

FINDINGS = {
    "second_mode": (True, "a second mode near the target beats with it"),
    "drift": (True, "frequency or damping drifts with time at a fixed amplitude"),
    "clipping": (True, "a channel is clipped: the largest amplitudes are wrong"),
    "no_pretrigger": (False, "the record starts after the impact: the largest amplitudes are missing"),
    "truncated_record": (False, "the record ends before the decay does: the smallest amplitudes are missing"),
}
"""Finding -> (outside any backbone library: the loop's verdict is "unexplained" with it; what it means)."""

TREND_BANDWIDTH = 0.01  # low-pass cut-off of the fitted mode's ln A and psi, fraction of the mode frequency
FLOOR_BANDWIDTH = 0.05  # width of the running median that is the local noise floor, fraction of the mode frequency
BLOCK_PERIODS = 10  # envelope blocks (median) for the noise floor and the end of the decay, periods
CLIPPED_SAMPLES = 3
PRETRIGGER_SAMPLES = 4
PRETRIGGER_LEVEL = 0.1
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


def damped_sinusoid(time: np.ndarray, residual: np.ndarray, frequency_hz: float, bounds_hz):
    """Least-squares fit of c exp((-sigma + i 2 pi f) t) to a complex (n,) residual, t from its first sample:
    (f Hz, sigma 1/s, c). c is solved linearly for each (f, sigma)."""
    elapsed = time - time[0]

    def fitted(parameters):
        basis = np.exp((-parameters[1] + 2j * np.pi * parameters[0]) * elapsed)
        return basis, np.vdot(basis, residual) / np.vdot(basis, basis).real

    def misfit(parameters):
        basis, amplitude = fitted(parameters)
        difference = residual - amplitude * basis
        return np.concatenate([difference.real, difference.imag])

    start = [frequency_hz, 1.0 / (elapsed[-1] + elapsed[1])]
    result = least_squares(misfit, start, bounds=([bounds_hz[0], 0.0], [bounds_hz[1], np.inf]), x_scale=[0.1, 1.0])
    return result.x[0], result.x[1], fitted(result.x)[1]


def second_mode(time: np.ndarray, residual: np.ndarray, target: np.ndarray, mode_frequency_hz: float, band_hz,
                false_alarm: float):
    """The second mode in the analytic residual (n,) of one channel with the target removed, as a dict of
    evidence, or None when the residual's largest peak outside the target's frequencies is within the noise
    (module docstring). time: (n,) s from the impact; target: (n,) the target mode's slow analytic signal z_1 in
    that channel (its frequencies are left out of the search; the amplitude is relative to |z_1| at the impact)."""
    step = time[1] - time[0]
    cutoff = TREND_BANDWIDTH * mode_frequency_hz
    n_fft = 4 * 2 ** int(np.ceil(np.log2(residual.size)))
    frequency = np.fft.fftfreq(n_fft, step)
    power = np.abs(np.fft.fft(residual, n_fft)) ** 2
    floor = scipy.ndimage.median_filter(power, size=int(FLOOR_BANDWIDTH * mode_frequency_hz * n_fft * step),
                                        mode="nearest") / np.log(2)  # median of an exponential = ln 2 mean
    instantaneous = np.gradient(np.unwrap(np.angle(target)), step) / (2 * np.pi)
    own = np.percentile(instantaneous, [1, 99]) + np.array([-2 * cutoff, 2 * cutoff])
    searched = ((frequency > band_hz[0]) & (frequency < band_hz[1])
                & ((frequency < own[0]) | (frequency > own[1])))
    independent = np.count_nonzero(searched) * residual.size / n_fft  # frequencies 1 / duration apart
    threshold = np.log(independent / false_alarm)
    ratio = np.where(searched, power / floor, 0.0)
    peak = int(np.argmax(ratio))
    if ratio[peak] <= threshold:
        return None
    found_hz, decay_rate, amplitude = damped_sinusoid(time, residual, frequency[peak], band_hz)
    return {"frequency_hz": found_hz, "relative_amplitude": abs(amplitude) / abs(target[0]),
            "damping_ratio": decay_rate / (2 * np.pi * found_hz),
            "target_frequency_hz": float(np.median(instantaneous)), "peak_over_floor": ratio[peak],
            "threshold": threshold}


def target_removed(hit: RingDown, mode_frequency_hz: float, band_hz):
    """Per channel of one hit: (label, time (m,) s, analytic residual (m,), target's analytic signal (m,)) over
    the decay, from the envelope maximum of the target to its noise floor (:func:`decay_span`).

    Several channels: the target is the strongest component of the band-passed channels (its shape s from
    ``experiment.modal_filter.dominant_shape``, its coordinate q = s^+ y), removed channel by channel, y_c - s_c q:
    a mode of another shape stays in the residual whatever its size. One channel: the target is the slow part of
    ln z (:func:`experiment.hilbert.slow_part`), which follows the stronger of two beating modes."""
    filtered = band_pass(hit.signals, hit.sample_rate, *band_hz)
    period = hit.sample_rate / mode_frequency_hz
    cutoff = TREND_BANDWIDTH * mode_frequency_hz
    if filtered.shape[0] == 1:
        start, stop = decay_span(np.abs(scipy.signal.hilbert(filtered[0])), int(BLOCK_PERIODS * period))
        z = analytic_signal(filtered[0, start:stop], period)
        target = slow_part(z, hit.sample_rate, cutoff)
        return [(f"{hit.hit}: {hit.channels[0]}", hit.time[start:stop], z - target, target)]
    shape = dominant_shape(filtered)
    modal = modal_coordinates(filtered, shape)[0]
    start, stop = decay_span(np.abs(scipy.signal.hilbert(modal)), int(BLOCK_PERIODS * period))
    target = slow_part(analytic_signal(modal[start:stop], period), hit.sample_rate, cutoff)
    return [(f"{hit.hit}: {name}", hit.time[start:stop],
             analytic_signal(signal[start:stop] - value * modal[start:stop], period), value * target)
            for name, signal, value in zip(hit.channels, filtered, shape)]


def second_mode_findings(hits: list[RingDown], mode_frequency_hz: float, band_hz) -> list[dict]:
    """:func:`second_mode` on every channel of every hit (:func:`target_removed`), ``FALSE_ALARM`` shared among
    them; one finding with the median frequency and relative amplitude over the channels where it is seen (empty
    if none)."""
    channels = [entry for hit in hits for entry in target_removed(hit, mode_frequency_hz, band_hz)]
    seen = {label: second_mode(time, residual, target, mode_frequency_hz, band_hz, FALSE_ALARM / len(channels))
            for label, time, residual, target in channels}
    seen = {label: evidence for label, evidence in seen.items() if evidence is not None}
    if not seen:
        return []
    frequency = float(np.median([e["frequency_hz"] for e in seen.values()]))
    amplitude = float(np.median([e["relative_amplitude"] for e in seen.values()]))
    target = float(np.median([e["target_frequency_hz"] for e in seen.values()]))
    return [finding("second_mode", f"a second mode at {frequency:.4g} Hz ({100 * (frequency / target - 1):+.2f} % of "
                    f"the target's {target:.4g} Hz) with {100 * amplitude:.3g} % of its amplitude at the impact, "
                    f"in {len(seen)} of {len(channels)} channels",
                    {"frequency_hz": frequency, "frequency_ratio": frequency / target, "relative_amplitude": amplitude,
                     "damping_ratio": float(np.median([e["damping_ratio"] for e in seen.values()])),
                     "channels_seen": sorted(seen), "channels_checked": len(channels),
                     "peak_over_floor": max(e["peak_over_floor"] for e in seen.values()),
                     "threshold": min(e["threshold"] for e in seen.values())})]


def hit_of(label: str) -> str:
    """The hit of a record's label ``<hit>: <channel or modal>`` (``experiment.backbone.mode_signals``)."""
    return label.rsplit(": ", 1)[0]


def drift_findings(hits: list[RingDown], measured: MeasuredBackbone) -> list[dict]:
    """Non-stationarity across hits (module docstring): frequency and damping regressed on time at fixed
    amplitude, each bin mean weighted by the inverse square of its standard error; a finding per quantity whose
    rate exceeds its noise (empty if none)."""
    grid = measured.hilbert.amplitude
    starts = {hit.hit: hit.time[0] for hit in hits}
    stamped = len(set(starts.values())) == len(starts)
    order = {hit.hit: number for number, hit in enumerate(hits)}
    unit, span = ("s", max(hit.time[-1] for hit in hits) - min(starts.values())) if stamped else ("hit", len(hits) - 1)
    found = []
    for name in ("natural_frequency_hz", "damping_ratio"):
        clocks, means, weights = [], [], []
        for record in measured.records:
            estimate = record.hilbert
            clock = binned_means(estimate.amplitude, estimate.time, grid)
            if not stamped:
                clock = np.where(np.isfinite(clock), order[hit_of(record.label)], np.nan)
            filled = np.flatnonzero(np.isfinite(clock))
            clock[filled[[0, -1]] if filled.size else []] = np.nan  # partly covered bins, where end effects sit
            values = getattr(estimate, name)
            error = binned_standard_error(estimate.amplitude, values,
                                          np.full(values.size, 1 / estimate.correlated_samples), grid)
            clocks.append(clock)
            means.append(binned_means(estimate.amplitude, values, grid))
            usable = np.isfinite(clock) & (error > 0)
            weights.append(np.where(usable, 1 / np.where(usable, error, 1.0) ** 2, 0.0))
        clock, mean, weight = np.array(clocks), np.nan_to_num(np.array(means)), np.array(weights)
        weight[:, np.count_nonzero(weight, axis=0) < 2] = 0.0  # a level needs two records to compare
        total = np.sum(weight, axis=0)
        if np.count_nonzero(total) == 0:
            continue
        clock = np.nan_to_num(clock)
        per_level = np.where(total > 0, 1 / np.where(total > 0, total, 1), 0)
        x = clock - np.sum(weight * clock, axis=0) * per_level
        y = mean - np.sum(weight * mean, axis=0) * per_level
        dof = np.count_nonzero(weight) - np.count_nonzero(total) - 1
        if dof < 2 or not np.any(weight * x * x):
            continue
        rate = np.sum(weight * x * y) / np.sum(weight * x * x)
        scatter = np.sum(weight * (y - rate * x) ** 2) / dof  # chi^2 per degree of freedom scales the weights
        error = np.sqrt(scatter / np.sum(weight * x * x))
        critical = scipy.stats.t.isf(FALSE_ALARM / 4, dof)
        if abs(rate) > critical * error:
            level = float(np.sum(weight * mean) / np.sum(weight))
            label = "frequency" if name == "natural_frequency_hz" else "damping"
            found.append(finding("drift", f"the {label} {'rises' if rate > 0 else 'falls'} by "
                                 f"{rate / level:+.3g} of itself per {unit} at fixed amplitude "
                                 f"({rate * span / level:+.3g} over the {span:.4g} {unit} of the hits)",
                                 {"quantity": name, f"rate_per_{unit}": rate, f"relative_rate_per_{unit}": rate / level,
                                  "relative_change_over_span": rate * span / level, f"span_{unit}": span,
                                  "standard_error": error, "t": rate / error, "critical_t": critical,
                                  "clock": "time stamps of the hits" if stamped else "order of the hits"}))
    return found


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


def record_findings(hits: list[RingDown], mode_frequency_hz: float, band_hz) -> list[dict]:
    """Clipping, no pre-trigger and a truncated record (module docstring), one finding each with the channels
    where they are seen and a level per channel: the clipped value (signal unit), the first samples' mean
    |x - median| relative to the peak, the envelope where the record ends relative to its peak (dB); empty if
    none."""
    seen = {name: [] for name in ("clipping", "no_pretrigger", "truncated_record")}
    n_channels = sum(len(hit.channels) for hit in hits)
    levels = {name: [] for name in seen}
    for hit in hits:
        block = int(BLOCK_PERIODS * hit.sample_rate / mode_frequency_hz)
        filtered = band_pass(hit.signals, hit.sample_rate, *band_hz)
        for name, raw, signal in zip(hit.channels, hit.signals, filtered):
            label = f"{hit.hit}: {name}"
            peak = np.max(np.abs(raw))
            at_extreme = np.isclose(np.abs(raw), peak, rtol=1e-9, atol=0.0)
            runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], at_extreme.astype(int), [0]]))))[::2]
            if runs.max() >= CLIPPED_SAMPLES:
                seen["clipping"].append(label)
                levels["clipping"].append(peak)
            moving = np.mean(np.abs(raw[:PRETRIGGER_SAMPLES] - np.median(raw))) / np.max(np.abs(raw - np.median(raw)))
            if moving > PRETRIGGER_LEVEL:
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
    }
    return [finding(name, summaries[name](), {"channels": channels, "levels": [float(v) for v in levels[name]]})
            for name, channels in seen.items() if channels]


def ringdown_findings(hits: list[RingDown], measured: MeasuredBackbone, band_hz) -> dict:
    """Every check that applies to the hits and their backbone (module docstring): ``{"checked": [...],
    "found": [...]}``; drift is checked with three hits or more."""
    checked = ["second_mode", "clipping", "no_pretrigger", "truncated_record"]
    found = (second_mode_findings(hits, measured.mode_frequency_hz, band_hz)
             + record_findings(hits, measured.mode_frequency_hz, band_hz))
    if len(hits) >= 3:
        checked.append("drift")
        found += drift_findings(hits, measured)
    return {"checked": checked, "found": found}
