"""The structures of a study: a superelement, the mode the measurement saw, and the measured backbone to fit.

A structure is what paper section 4.4 compares a model with: one reduced model (the project's beams from
``build/rom/<beam>.npz``, or an external ASB model), the target mode chosen to be the measured one, and the
measured (or virtual) backbone reduced to the levels at which the model is evaluated.

Target mode: ``reduction.superelement.target_mode``.

Levels. A measured backbone holds hundreds to thousands of scattered estimates (ASB) or a few tens of averaged
points (ring-downs). Its amplitude range is cut into ``n_levels`` bins of equal logarithmic width (edges at the
geometric midpoints of log-spaced targets); each bin with points gives one level: the median amplitude,
frequency and damping of its points. The model is evaluated at those modal amplitudes (measured ones for an
averaged backbone), so the L-infinity errors of paper Eqs. 26-27 are taken at the measured amplitudes, robust
against the scatter of single estimates; bins without points (a gap between hits) give no level.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from experiment.backbone import Backbone, ModeBackbone
from nonlinear.condensation import JointSpace, joint_space
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import StructureError, Superelement, read_asb_superelement, target_mode

N_LEVELS = 20  # modal amplitudes per structure at which designs are evaluated
MIN_POINTS = 3  # a measured backbone needs at least this many amplitudes


FREQUENCY_FLOOR = 1e-4  # relative floor of a level's frequency uncertainty in fits (1e-4 f)
DAMPING_FLOOR = 2e-2  # relative floor of a level's damping uncertainty in fits (2 % of zeta)


@dataclass(frozen=True)
class BackboneLevels:
    """A structure's measured (or virtual) backbone reduced to the levels where models are compared with it: one
    median point per amplitude bin with the median's uncertainty, the one record of a measurement that the study,
    the calibration and the discrepancy loop compute with (made by :func:`measured_levels` from a
    :class:`~experiment.backbone.ModeBackbone`).

    amplitude: (n,) modal amplitudes q (m kg^0.5), positive and increasing, n >= MIN_POINTS; frequency_hz: (n,)
    natural frequency (Hz); damping: (n,) damping ratio; frequency_uncertainty_hz, damping_uncertainty: (n,)
    standard uncertainty of each level's median (NaN where unknown); low_amplitude_frequency_hz: the measurement's
    natural frequency at its lowest amplitude with data; provenance: "measured" or "virtual"; source: where the
    backbone came from. A record that breaks these raises StructureError naming the source and the field.
    """

    amplitude: np.ndarray
    frequency_hz: np.ndarray
    damping: np.ndarray
    frequency_uncertainty_hz: np.ndarray
    damping_uncertainty: np.ndarray
    low_amplitude_frequency_hz: float
    provenance: str
    source: str

    def __post_init__(self):
        for name in ("amplitude", "frequency_hz", "damping"):
            if not np.all(np.isfinite(np.asarray(getattr(self, name), dtype=float))):
                raise StructureError(f"{self.source}: field {name}: NaN or infinite values")
        if len(self.amplitude) < MIN_POINTS or np.any(np.diff(self.amplitude) <= 0) or self.amplitude[0] <= 0:
            raise StructureError(f"{self.source}: field amplitude: expected at least {MIN_POINTS} positive, "
                                 f"increasing amplitudes; got {len(self.amplitude)}")

    @cached_property
    def sigma_frequency(self) -> np.ndarray:
        """(n,) Hz: the standard uncertainty a fit divides the frequency residual by, at least FREQUENCY_FLOOR f."""
        return np.fmax(np.nan_to_num(self.frequency_uncertainty_hz, nan=0.0), FREQUENCY_FLOOR * self.frequency_hz)

    @cached_property
    def sigma_damping(self) -> np.ndarray:
        """(n,): the standard uncertainty a fit divides the damping residual by, at least DAMPING_FLOOR zeta."""
        return np.fmax(np.nan_to_num(self.damping_uncertainty, nan=0.0), DAMPING_FLOOR * np.abs(self.damping))


@dataclass(frozen=True)
class Structure:
    """One structure of a study: name, joint space (superelement and the target mode's reference shape),
    measurement at the levels, linear damping zeta_0 of its other mechanisms, and how the mode was chosen."""

    name: str
    space: JointSpace
    measurement: BackboneLevels
    linear_damping: float
    mode_choice: str


def measured_levels(measured: ModeBackbone, n_levels: int = N_LEVELS, path: str = "backbone") -> BackboneLevels:
    """The measured backbone's medians in up to ``n_levels`` log-spaced amplitude bins (module docstring).
    Raises StructureError naming ``path`` and the field for NaN values, a non-positive frequency, a negative
    damping ratio, fewer than MIN_POINTS amplitudes (or filled bins), a non-positive or non-increasing amplitude."""
    backbone = measured.backbone
    amplitude = np.asarray(backbone.amplitude, dtype=float)
    columns = {"modal_amplitude": amplitude, "natural_frequency": np.asarray(backbone.natural_frequency_hz, float),
               "damping_ratio": np.asarray(backbone.damping_ratio, float)}
    for field, values in columns.items():
        if not np.all(np.isfinite(values)):
            raise StructureError(f"{path}: field {field}: {np.sum(~np.isfinite(values))} NaN or infinite values "
                                 "(expected finite numbers at every point)")
    out_of_range = {"natural_frequency": (columns["natural_frequency"] <= 0.0, "positive frequencies (Hz)"),
                    "damping_ratio": (columns["damping_ratio"] < 0.0, "non-negative ratios (fraction of critical)")}
    for field, (bad, expected) in out_of_range.items():
        if np.any(bad):
            raise StructureError(f"{path}: field {field}: {np.sum(bad)} value(s) out of range, the first "
                                 f"{columns[field][bad][0]:.6g} (expected {expected} at every point)")
    if amplitude.size < MIN_POINTS:
        raise StructureError(f"{path}: field modal_amplitude: {amplitude.size} points (expected at least "
                             f"{MIN_POINTS})")
    if amplitude[0] <= 0.0 or np.any(np.diff(amplitude) < 0.0) or amplitude[-1] <= amplitude[0]:
        raise StructureError(f"{path}: field modal_amplitude: expected positive amplitudes in non-decreasing order "
                             f"spanning a range; got {amplitude[:3].tolist()}...{amplitude[-2:].tolist()}")
    targets = np.geomspace(amplitude[0], amplitude[-1], n_levels)
    edges = np.sqrt(targets[1:] * targets[:-1])
    bins = np.searchsorted(edges, amplitude, side="right")
    filled = np.flatnonzero(np.bincount(bins, minlength=n_levels))
    if filled.size < MIN_POINTS:
        raise StructureError(f"{path}: field modal_amplitude: points in {filled.size} of {n_levels} amplitude bins "
                             f"(expected at least {MIN_POINTS})")
    levels, frequency, damping = (np.array([np.median(values[bins == i]) for i in filled]) for values in columns.values())
    uncertainties = (median_uncertainty(columns[name], stated, bins, filled) for name, stated in (
        ("natural_frequency", backbone.natural_frequency_uncertainty_hz), ("damping_ratio", backbone.damping_ratio_uncertainty)))
    return BackboneLevels(levels, frequency, damping, *uncertainties, float(measured.low_amplitude_frequency_hz),
                          measured.provenance, measured.source)


def median_uncertainty(values, stated, bins, filled) -> np.ndarray:
    """Standard uncertainty of each filled bin's median: from the scatter of its points where it holds three or
    more (1.2533 s / sqrt(n), the median's standard error for normal scatter), else the points' stated
    uncertainty (root mean square; NaN where none is stated or it is zero)."""
    result = []
    for i in filled:
        inside = values[bins == i]
        if inside.size >= 3:
            result.append(1.2533 * np.std(inside, ddof=1) / np.sqrt(inside.size))
        else:
            given = np.asarray(stated, dtype=float)[bins == i]
            result.append(np.sqrt(np.mean(given ** 2)) if np.all(given > 0) else np.nan)
    return np.array(result)


def asb_superelement(path: Path) -> Superelement:
    """An ASB configuration's reduced model with every patch in one parameter group, so that one design is the
    same joint in all six configurations (C1-C4a have four equal square patches, CD1 five in a row)."""
    path = Path(path)
    if not path.exists():
        raise StructureError(f"{path}: missing (the ASB reduced models: surrogacy data fetch downloads them)")
    superelement = read_asb_superelement(path)
    return read_asb_superelement(path, patch_groups=(0,) * superelement.n_patches)


def structure(name: str, superelement: Superelement, measured: ModeBackbone, linear_damping: float,
              n_levels: int = N_LEVELS, measurement_path: str = "backbone") -> Structure:
    """A structure: the target mode chosen from the measurement, the joint space tracking it, the levels."""
    measurement = measured_levels(measured, n_levels, measurement_path)
    _, shape, choice = target_mode(superelement, measurement.low_amplitude_frequency_hz)
    return Structure(name, joint_space(superelement, reference_mode=shape), measurement, float(linear_damping), choice)


def qsma_measurement(space: JointSpace, name: str, model: str, design, amplitudes, linear_damping: float
                     ) -> ModeBackbone:
    """A virtual measurement with a known answer: the QSMA backbone of one ``design`` of ``model`` at
    ``amplitudes`` (m kg^0.5), labelled virtual (for tests of the study and its benchmark)."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    result = qsma_designs(space, model, np.atleast_2d(design), amplitudes=amplitudes, linear_damping=linear_damping)
    if not result.converged.all():
        raise StructureError(f"{name}: QSMA of the design did not converge ({set(result.reason[0])})")
    unknown = np.full(amplitudes.size, np.nan)
    backbone = Backbone(amplitudes, result.frequency[0] / (2 * np.pi), unknown, unknown, result.damping[0], unknown,
                        unknown, np.ones(amplitudes.size, dtype=int))
    return ModeBackbone(name, float(backbone.natural_frequency_hz[0]), "m kg^0.5", "virtual",
                        f"QSMA of {model} design {np.ravel(design).tolist()}", backbone)
