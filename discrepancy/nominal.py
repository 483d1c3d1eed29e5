"""The nominal of the one-mode model: the low-amplitude natural frequency f_0 and linear damping ratio zeta_0 that
the discrepancy loop's reference model starts from, given by the user or estimated from the measurement.

Estimate (:func:`low_amplitude_nominal`). In the microslip regime of a joint the frequency's fall and the damping's
rise grow about linearly with amplitude (the four-parameter Iwan law, whose dissipation per cycle goes as
F^(3 + chi) in microslip, makes both go as q^(1 + chi), chi near 0: Segalman, J. Appl. Mech. 72, 2005; and to first
order any smooth backbone), and the nominal is their limit at zero amplitude. Over the measurement's lowest decade
of amplitude a straight line in amplitude is fitted to frequency and to damping by weighted least squares, each
level weighted by its stated uncertainty (``BackboneLevels.sigma_frequency``, ``sigma_damping``), so that the
noise-dominated lowest levels weigh little; the intercepts are the nominal and
their standard errors come from the fit's covariance, scaled up by sqrt(chi^2/dof) where the levels scatter more
than stated. A level more than :data:`OUTLIER_SIGMAS` standard deviations off a Huber-weighted first fit is left
out (one noisy level cannot move the nominal); where the backbone bends within the window (a quadratic term in
amplitude more than :data:`BEND_SIGMAS` standard errors from zero, in frequency or damping) the window shrinks from
the top, to no fewer than :data:`MIN_LEVELS` levels. The nominal never comes from one level.

Limit: the line stands for the microslip regime. A measurement that starts above it (the damping doubling within its
lowest decade, as the ASB CD1 and CD2 backbones do) gives a nominal that depends on how the backbone is continued
below its lowest level; the standard errors do not include that. Give the model's nominal there.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from discrepancy.effects import offset_effect
from study.structures import BackboneLevels

DECADES = 1.0  # the low-amplitude window: levels within this many decades of the lowest one
MIN_LEVELS = 4  # the fewest levels a window holds (all of them where the measurement has fewer)
OUTLIER_SIGMAS = 4.0  # a level this many stated standard deviations off the first fit is left out
HUBER_SIGMAS = 2.0  # residuals beyond this many standard deviations are down-weighted in the first fit
BEND_SIGMAS = 3.0  # a quadratic term this many standard errors from zero: the backbone bends within the window


class NominalError(ValueError):
    """A nominal value out of range: ``parameter`` (``frequency_hz`` or ``damping``), its ``value`` and what was
    ``expected``."""

    def __init__(self, parameter: str, value, expected: str):
        self.parameter, self.value, self.expected = parameter, value, expected
        super().__init__(f"nominal {parameter} = {value!r}: expected {expected}")


def checked_nominal(frequency_hz: float | None, damping: float | None) -> None:
    """Refuse a given nominal that no linear mode has: a frequency that is not a positive finite number (Hz), a
    damping ratio outside [0, 1) (an underdamped mode) or not finite. None: not given. Raises NominalError."""
    if frequency_hz is not None and not (np.isfinite(frequency_hz) and frequency_hz > 0.0):
        raise NominalError("frequency_hz", frequency_hz, "a positive finite natural frequency in Hz")
    if damping is not None and not (np.isfinite(damping) and 0.0 <= damping < 1.0):
        raise NominalError("damping", damping, "a finite damping ratio in [0, 1) (fraction of critical)")


class Nominal(NamedTuple):
    """The nominal low-amplitude frequency (Hz) and linear damping ratio with their standard errors, and a line
    saying where they came from."""

    frequency_hz: float
    frequency_standard_error_hz: float
    damping: float
    damping_standard_error: float
    source: str


class LineFit(NamedTuple):
    """A weighted straight line through (amplitude, value): intercept and slope, the intercept's standard error,
    chi^2 and degrees of freedom over the levels used, and the mask of the levels left out as outliers."""

    intercept: float
    slope: float
    intercept_standard_error: float
    chi_squared: float
    dof: int
    outliers: np.ndarray


def weighted_line(amplitude: np.ndarray, values: np.ndarray, sigma: np.ndarray) -> LineFit:
    """Weighted least-squares line values = a + b amplitude over (n,) levels with standard uncertainties sigma (n,):
    a Huber-weighted fit (:data:`HUBER_SIGMAS`) finds the levels more than :data:`OUTLIER_SIGMAS` off, which are
    left out of the final plain fit where at least three levels remain. The intercept's standard error is the
    covariance's, times sqrt(chi^2 / dof) where that exceeds one."""
    scale = np.max(amplitude)  # the normal equations in amplitude / its largest value: well conditioned
    design = np.stack([np.ones_like(amplitude), amplitude / scale], axis=1)

    def solve(weights):
        normal = design.T @ (weights[:, None] / sigma[:, None] ** 2 * design)
        covariance = np.linalg.inv(normal)
        coefficients = covariance @ design.T @ (weights / sigma ** 2 * values)
        return coefficients, covariance, (values - design @ coefficients) / sigma

    weights = np.ones_like(values)
    for _ in range(50):
        coefficients, covariance, residual = solve(weights)
        updated = np.minimum(1.0, HUBER_SIGMAS / np.maximum(np.abs(residual), 1e-300))
        if np.allclose(updated, weights, rtol=0, atol=1e-9):
            break
        weights = updated
    outliers = np.abs(residual) > OUTLIER_SIGMAS
    if np.sum(~outliers) < 3:
        outliers[:] = False
    coefficients, covariance, residual = solve((~outliers).astype(float))
    chi_squared = float(np.sum(residual[~outliers] ** 2))
    dof = int(np.sum(~outliers)) - 2
    inflation = max(1.0, np.sqrt(chi_squared / dof)) if dof > 0 else 1.0
    return LineFit(float(coefficients[0]), float(coefficients[1] / scale), float(np.sqrt(covariance[0, 0]) * inflation),
                   chi_squared, dof, outliers)


def bends(amplitude: np.ndarray, values: np.ndarray, sigma: np.ndarray) -> bool:
    """Whether a weighted quadratic in amplitude through (n,) levels has its quadratic term more than
    :data:`BEND_SIGMAS` standard errors (scaled by sqrt(chi^2/dof) where that exceeds one) from zero."""
    if amplitude.size < 4:
        return False
    scaled = amplitude / amplitude[-1]
    design = np.stack([np.ones_like(scaled), scaled, scaled ** 2], axis=1)
    covariance = np.linalg.inv(design.T @ (design / sigma[:, None] ** 2))
    coefficients = covariance @ design.T @ (values / sigma ** 2)
    chi_squared = np.sum(((values - design @ coefficients) / sigma) ** 2)
    inflation = max(1.0, np.sqrt(chi_squared / (amplitude.size - 3)))
    return abs(coefficients[2]) > BEND_SIGMAS * np.sqrt(covariance[2, 2]) * inflation


def low_amplitude_nominal(measurement: BackboneLevels, decades: float = DECADES) -> Nominal:
    """The nominal f_0 (Hz) and zeta_0 of a measurement with their standard errors: weighted lines in amplitude
    through its levels within ``decades`` of the lowest amplitude (at least :data:`MIN_LEVELS`), extrapolated to
    zero amplitude (module docstring). A damping intercept below zero is set to zero, as the source says."""
    amplitude = np.asarray(measurement.amplitude, dtype=float)
    in_decades = int(np.sum(amplitude <= amplitude[0] * 10.0 ** decades))
    count = max(in_decades, min(MIN_LEVELS, amplitude.size))
    quantities = [(np.asarray(values, dtype=float), np.asarray(sigma, dtype=float)) for values, sigma in
                  ((measurement.frequency_hz, measurement.sigma_frequency),
                   (measurement.damping, measurement.sigma_damping))]
    while count > MIN_LEVELS and any(bends(amplitude[:count], values[:count], sigma[:count])
                                     for values, sigma in quantities):
        count -= 1
    frequency, damping = (weighted_line(amplitude[:count], values[:count], sigma[:count])
                          for values, sigma in quantities)
    left_out = [f"the level at {amplitude[index]:.3g} from the {name} ({name} {values[index]:.6g}, more than "
                f"{OUTLIER_SIGMAS:g} standard deviations off the line)"
                for name, line, values in (("frequency", frequency, measurement.frequency_hz),
                                           ("damping", damping, measurement.damping))
                for index in np.flatnonzero(line.outliers)]
    window = (f"the lowest {decades:g} decade(s)" if count == in_decades else
              f"the lowest {decades:g} decade(s), cut below a bend" if count < in_decades else
              f"{in_decades} in the lowest {decades:g} decade(s)")
    source = (f"estimated from the measurement: weighted lines in amplitude through its {count} lowest levels "
              f"({amplitude[0]:.3g} to {amplitude[count - 1]:.3g}: {window}) extrapolated to zero amplitude, each "
              f"level weighted by its stated uncertainty (chi^2/dof "
              f"{ratio(frequency)} frequency, {ratio(damping)} damping)"
              + (f"; left out {', '.join(left_out)}" if left_out else "")
              + ("; the damping's intercept fell below zero and is set to zero" if damping.intercept < 0 else ""))
    return Nominal(frequency.intercept, frequency.intercept_standard_error, max(damping.intercept, 0.0),
                   damping.intercept_standard_error, source)


def ratio(line: LineFit) -> str:
    """chi^2/dof of a line fit as text ("-" without degrees of freedom)."""
    return f"{line.chi_squared / line.dof:.2g}" if line.dof > 0 else "-"


NOMINAL_VALUES = {"frequency": ("f_0", "--nominal-frequency-hz"), "damping": ("zeta_0", "--nominal-damping")}
"""Nominal value -> (its symbol, the option that gives it); the offset effect it stands in for is the registry's
(``discrepancy.effects.offset_effect``): an offset at every amplitude and the nominal are one number."""


def offset_caveat(estimated) -> str | None:
    """What a nominal estimated from the measurement itself cannot tell (None where every nominal value was given):
    an offset outside the joint at every amplitude (a mass or stiffness change, a linear damping) shifts the
    measurement's low-amplitude limit exactly as a different nominal does, so the estimate holds it, within its
    standard errors, and the loop's offset effects only test whether the measurement departs from its own
    low-amplitude extrapolation. ``estimated``: the nominal values estimated, "frequency" and/or "damping"."""
    entries = [(*NOMINAL_VALUES[name], offset_effect(name)) for name in ("frequency", "damping") if name in estimated]
    if not entries:
        return None
    return (f"The nominal {' and '.join(symbol for symbol, _, _ in entries)} is estimated from this measurement, "
            f"so an offset at every amplitude ({'; '.join(f'{e.what}, {e.name}' for _, _, e in entries)}) "
            "cannot be told from it: the estimate holds such an offset within its standard errors, and "
            f"{' and '.join(e.name for _, _, e in entries)} {'are' if len(entries) > 1 else 'is'} named only "
            "where the fit pulls the nominal beyond them. Against the structure's model, the offset is this "
            f"nominal minus the model's; give the model's ({', '.join(option for _, option, _ in entries)}) "
            "to test for it.")


def nominal_statement(record: dict) -> list[str]:
    """Markdown lines stating the nominal a loop on a file started from, where it came from and, for a nominal
    estimated from the measurement, what it cannot tell (``offset_caveat``; the record's ``nominal_*`` keys);
    nothing for a record without them (a study's structure)."""
    if "nominal_frequency_hz" not in record:
        return []
    errors = [f" +- {record[key]:.2g}" if record.get(key) else "" for key in
              ("nominal_frequency_standard_error_hz", "nominal_damping_standard_error")]
    source = ("given (--nominal-frequency-hz, --nominal-damping)" if record["nominal_source"] == "given"
              else record["nominal_source"])
    caveat = record.get("nominal_caveat")
    return [f"Nominal of the reference model: f_0 = {record['nominal_frequency_hz']:.8g}{errors[0]} Hz, zeta_0 = "
            f"{record['nominal_damping']:.4g}{errors[1]}; {source}.", "", *([caveat, ""] if caveat else [])]


def nominal_record(measurement: BackboneLevels, frequency_hz: float | None, damping: float | None) -> dict:
    """The nominal the loop starts from: the given values (``frequency_hz`` Hz, ``damping`` the linear damping
    ratio), and for any not given (None) the measurement's low-amplitude estimate (``low_amplitude_nominal``), with
    standard errors (0 for a given value), a ``nominal_source`` saying where they came from and a ``nominal_caveat``
    saying which offsets an estimated nominal holds (``offset_caveat``; None where both were given)."""
    estimate = (low_amplitude_nominal(measurement) if frequency_hz is None or damping is None else None)
    given = [name for name, value in (("frequency", frequency_hz), ("damping", damping)) if value is not None]
    source = ("given" if len(given) == 2 else estimate.source if not given else
              f"{given[0]} given; {'damping' if given[0] == 'frequency' else 'frequency'} {estimate.source}")
    return {"nominal_frequency_hz": frequency_hz if frequency_hz is not None else estimate.frequency_hz,
            "nominal_frequency_standard_error_hz": 0.0 if frequency_hz is not None
            else estimate.frequency_standard_error_hz,
            "nominal_damping": damping if damping is not None else estimate.damping,
            "nominal_damping_standard_error": 0.0 if damping is not None else estimate.damping_standard_error,
            "nominal_source": source,
            "nominal_caveat": offset_caveat([name for name, value in (("frequency", frequency_hz),
                                                                        ("damping", damping)) if value is None])}
