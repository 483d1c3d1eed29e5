"""What a calibration varies and what it compares: the unit box of a friction model's joint parameters and the
structure's linear damping zeta_0, and the model's backbone against the measurement at its levels.

Box. The first d coordinates are the model's Table 3 parameters mapped to [0, 1] as the study samples them
(``nonlinear.joint.from_unit``: in log where Table 3 is logarithmic). The last is zeta_0, the damping of the
structure outside the joint, in log between ``ZETA0_FLOOR`` and ``ZETA0_CEILING`` times the smallest measured
damping ratio: zeta_0 is fitted, not taken from the lowest measured point, which already holds the joint's own
microslip damping (adding the joint's damping to that counts it twice).

Backbone. QSMA (``nonlinear.qsma_vectorised.qsma_designs``, amplitude control at the measured levels, the joint
alone) gives omega_j(q) and zeta_j(q); the model's frequency is omega_j / 2 pi and its damping zeta_j + zeta_0
(paper Eqs. 22-25 with the linear damping added as in the study).

Errors. The L-infinity errors of paper Eqs. 26-27, e_f = max |f - f_m| (Hz) and e_zeta = max |zeta - zeta_m|, are
the objectives of the global search (the study's, so fronts compare). The residuals of the local fit are the same
differences divided by the measurement's standard uncertainty at each level
(``study.structures.BackboneLevels.sigma_frequency``, ``sigma_damping``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.condensation import ModalSplit, modal_split
from nonlinear.joint import from_unit, parameter_limits, parameter_names, to_unit
from nonlinear.qsma_vectorised import qsma_designs
from study.errors import curve_errors
from study.pareto import non_dominated
from study.structures import BackboneLevels, Structure

ZETA0_FLOOR = 1e-6
"""Lower bound of zeta_0 (-): no damping outside the joint, to the precision that matters."""
ZETA0_CEILING = 1.5
"""Upper bound of zeta_0 as a multiple of the smallest measured damping ratio (the joint's damping is not
negative; the half above it leaves room for the scatter of the lowest level)."""


class FitSpace(NamedTuple):
    """The calibration box of one friction model on one structure: the limits of its d + 1 coordinates (lower,
    upper, logarithmic, each (d + 1,): the design's Table 3 limits, then zeta_0's (-), logarithmic) and their
    names."""

    model: str
    lower: np.ndarray
    upper: np.ndarray
    logarithmic: np.ndarray
    names: tuple[str, ...]


def fit_space(model: str, n_groups: int, measurement: BackboneLevels) -> FitSpace:
    """The box of ``model`` with ``n_groups`` parameter groups for the structure that made ``measurement``."""
    lower, upper, logarithmic = parameter_limits(model, n_groups)
    ceiling = max(ZETA0_CEILING * float(np.min(measurement.damping)), 10.0 * ZETA0_FLOOR)
    return FitSpace(model, np.append(lower, ZETA0_FLOOR), np.append(upper, ceiling), np.append(logarithmic, True),
                    (*parameter_names(model, n_groups), "zeta_0"))


def physical(space: FitSpace, unit) -> tuple[np.ndarray, np.ndarray]:
    """Designs (n, d) in physical units (N, N/m, -) and zeta_0 (n,) of unit points (n, d + 1)."""
    values = from_unit(np.atleast_2d(unit), space.lower, space.upper, space.logarithmic)
    return values[:, :-1], values[:, -1]


def unit_zeta0(space: FitSpace, zeta0) -> np.ndarray:
    """The last unit coordinate of zeta_0 values (clipped to the box)."""
    zeta0 = np.maximum(zeta0, space.lower[-1])
    return np.clip(to_unit(zeta0, space.lower[-1], space.upper[-1], True), 0.0, 1.0)


class BackboneSolver(NamedTuple):
    """How a calibration solves one structure's backbones: its modal split, formed once for every call
    (``nonlinear.condensation.modal_split``; None: formed at each call), and the compute device of the stuck modes
    and QSMA levels (``nonlinear.compute_devices``: "cpu" or "cuda", the results agreeing to round-off)."""

    split: ModalSplit | None = None
    device: str = "cpu"


def backbone_solver(structure: Structure, device: str = "cpu") -> BackboneSolver:
    """The ``BackboneSolver`` of ``structure`` on ``device``, its modal split formed here."""
    return BackboneSolver(modal_split(structure.space), device)


class Curves(NamedTuple):
    """Model backbones at the measured levels: frequency_hz and damping (n, levels); converged (n,): QSMA
    converged at every level (rows that did not are NaN)."""

    frequency_hz: np.ndarray
    damping: np.ndarray
    converged: np.ndarray


def profiled_zeta0(space: FitSpace, measurement: BackboneLevels, joint_damping) -> np.ndarray:
    """zeta_0 (n,) of least plain chi^2 for the joint's own damping ratios (n, levels): the damping residuals
    (zeta_j + zeta_0 - zeta_m) / sigma_zeta are linear in zeta_0, so the optimum is the sigma^-2 weighted mean of
    zeta_m - zeta_j, clipped to zeta_0's limits (chi^2 is a parabola in zeta_0)."""
    weights = measurement.sigma_damping ** -2.0
    optimum = np.sum((measurement.damping - np.atleast_2d(joint_damping)) * weights, axis=1) / np.sum(weights)
    return np.clip(optimum, space.lower[-1], space.upper[-1])


def model_curves(structure: Structure, space: FitSpace, unit, solver: BackboneSolver = BackboneSolver(),
                 archive: FrontArchive | None = None) -> Curves:
    """The backbones of unit points (n, d + 1) at the structure's measured levels (module docstring), solved by
    ``solver``; the points and their L-infinity errors are offered to ``archive`` (``FrontArchive``) where one is
    given."""
    designs, zeta0 = physical(space, unit)
    result = qsma_designs(structure.space, space.model, designs, amplitudes=structure.measurement.amplitude,
                          linear_damping=0.0, split=solver.split, device=solver.device)
    converged = result.converged.all(axis=1)
    frequency = np.where(converged[:, None], result.frequency / (2.0 * np.pi), np.nan)
    damping = np.where(converged[:, None], result.damping + zeta0[:, None], np.nan)
    curves = Curves(frequency, damping, converged)
    if archive is not None:
        archive.offer(unit, linf_errors(structure.measurement, curves))
    return curves


class FrontArchive:
    """The non-dominated set, in the two L-infinity errors, of every point a calibration evaluates: unit points
    (k, d + 1), their errors (k, 2) (e_f Hz, e_zeta -) and the phase that evaluated each (``source``, set by the
    caller before each phase). A point offered whose errors an archived point matches or beats in both (or that
    has a NaN error) is not added; the others are merged and the rows they dominate dropped
    (``study.pareto.non_dominated``), so the archive stays the front of everything evaluated so far."""

    def __init__(self, dimension: int):
        self.unit = np.empty((0, dimension))
        self.errors = np.empty((0, 2))
        self.sources: list[str] = []
        self.source = ""

    def offer(self, unit, errors) -> None:
        """Merge unit points (n, d + 1) and their errors (n, 2)."""
        unit, errors = np.atleast_2d(np.asarray(unit, dtype=float)), np.atleast_2d(errors)
        covered = np.all(self.errors[None, :, :] <= errors[:, None, :], axis=2).any(axis=1)
        fresh = np.flatnonzero(~covered & ~np.isnan(errors).any(axis=1))
        if not fresh.size:
            return
        merged_unit, merged_errors = np.vstack([self.unit, unit[fresh]]), np.vstack([self.errors, errors[fresh]])
        sources = self.sources + [self.source] * fresh.size
        keep = np.flatnonzero(non_dominated(merged_errors))
        self.unit, self.errors = merged_unit[keep], merged_errors[keep]
        self.sources = [sources[i] for i in keep]

    def front(self) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
        """The archive sorted by e_f, then e_zeta: unit (k, d + 1), errors (k, 2), sources (k,)."""
        order = np.lexsort((self.errors[:, 1], self.errors[:, 0]))
        return self.unit[order], self.errors[order], tuple(self.sources[i] for i in order)


def linf_errors(measurement: BackboneLevels, curves: Curves) -> np.ndarray:
    """(n, 2): e_f (Hz) and e_zeta (-), paper Eqs. 26-27 (``study.errors.curve_errors``, zeta_0 already in the
    curves); NaN rows where QSMA did not converge."""
    frequency, damping = curve_errors(curves.frequency_hz, curves.damping, measurement.frequency_hz,
                                      measurement.damping, [0.0])
    return np.column_stack([frequency, damping[:, 0]])


def plain_errors(measurement: BackboneLevels, curves: Curves) -> dict:
    """Relative errors of one backbone (the first row of ``curves``): max and RMS of |f - f_m| / f_m and of
    |zeta - zeta_m| / zeta_m over the levels, and the L-infinity errors in Hz and in damping ratio."""
    frequency = np.abs(curves.frequency_hz[0] - measurement.frequency_hz) / measurement.frequency_hz
    damping = np.abs(curves.damping[0] - measurement.damping) / measurement.damping
    return {"frequency_max_relative": float(np.max(frequency)),
            "frequency_rms_relative": float(np.sqrt(np.mean(frequency ** 2))),
            "damping_max_relative": float(np.max(damping)),
            "damping_rms_relative": float(np.sqrt(np.mean(damping ** 2))),
            "frequency_linf_hz": float(np.max(np.abs(curves.frequency_hz[0] - measurement.frequency_hz))),
            "damping_linf": float(np.max(np.abs(curves.damping[0] - measurement.damping)))}


def normalised_residuals(measurement: BackboneLevels, curves: Curves) -> tuple[np.ndarray, np.ndarray]:
    """(n, levels) each: (f - f_m) / sigma_f and (zeta - zeta_m) / sigma_zeta (module docstring)."""
    return ((curves.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency,
            (curves.damping - measurement.damping) / measurement.sigma_damping)
