"""The local phase of a calibration: weighted least squares from a point of the global front, and the
uncertainty of the parameters at the optimum.

Residual. For a weight w in (0, 1) between frequency and damping,

    r(u) = [sqrt(2 w) (f(u) - f_m) / sigma_f,  sqrt(2 (1 - w)) (zeta(u) - zeta_m) / sigma_zeta]   (2 n_levels,)

so that w = 1/2 is the plain chi^2 of both quantities (``calibration.objectives``). A point where QSMA does not
converge gets the residual ``UNDEFINED_RESIDUAL`` at every level: the trust region then shrinks away from it.

Method. scipy.optimize.least_squares, trust-region reflective in the unit box [0, 1]^(d+1) (log where Table 3
samples in log), the Jacobian by central differences of step ``STEP`` through one vectorised QSMA call of
2 (d + 1) designs (one-sided at a bound): ``box_least_squares``, which the discrepancy loop's refit on a
structure's superelement uses too (``discrepancy.superelement_route``). A fit is converged when least_squares stops on its tolerances
(status 1-4), not on its evaluation budget (status 0); a fit given ``continuations`` that stops on its budget is
restarted from where it stopped, up to that many times, and is reported as not converged if the last one stops on
its budget too.

Uncertainty. At the optimum u*, with J the Jacobian of the plain residual (w = 1/2), m residuals and p = d + 1
coordinates, the covariance of the unit coordinates is C = s^2 (J^T J)^+ with s^2 = chi^2 / (m - p) the reduced
chi^2 (the measurement's uncertainties are floors and estimates: their scale is taken from the fit, as
scipy.optimize.curve_fit does with absolute_sigma=False). A coordinate whose standard deviation exceeds
``UNDETERMINED`` of its unit range is not determined by the data (paper Table 4's "no clustering", quantified).
A log coordinate's uncertainty is a factor exp(sigma_u (ln hi - ln lo)) on the value; a linear one's
sigma_u (hi - lo).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from calibration.objectives import (BackboneSolver, FitSpace, FrontArchive, model_curves, normalised_residuals,
                                    physical)
from nonlinear.joint import sampling_scale
from study.structures import Structure

STEP = 1e-4
"""Finite-difference step in unit coordinates: Table 3 ranges span decades, so 1e-4 of a range moves a frequency
by about 1e-4 Hz, four orders above QSMA's accuracy (1e-8 relative)."""
UNDEFINED_RESIDUAL = 1e6
"""Residual at every level of a point where QSMA does not converge."""
UNDETERMINED = 0.25
"""Standard deviation of a unit coordinate above which the data leave the parameter undetermined."""


def residual_rows(structure: Structure, space: FitSpace, unit, weight: float,
                  solver: BackboneSolver = BackboneSolver(), archive: FrontArchive | None = None) -> np.ndarray:
    """Weighted residuals (n, 2 levels) of unit points (n, d + 1) (module docstring); every point evaluated is
    offered to ``archive``."""
    curves = model_curves(structure, space, unit, solver, archive)
    frequency, damping = normalised_residuals(structure.measurement, curves)
    rows = np.hstack([np.sqrt(2.0 * weight) * frequency, np.sqrt(2.0 * (1.0 - weight)) * damping])
    rows[~curves.converged] = UNDEFINED_RESIDUAL
    return rows


def difference_points(point: np.ndarray, lower=0.0, upper=1.0) -> tuple[np.ndarray, np.ndarray]:
    """The 2 p points of a central difference of step ``STEP`` around ``point`` (p,), kept inside the box
    [lower, upper] (scalars or (p,)), and each coordinate's step between its pair (2 STEP, or less at a bound)."""
    p = point.size
    above = np.minimum(point + STEP, upper)
    below = np.maximum(point - STEP, lower)
    points = np.repeat(point[None, :], 2 * p, axis=0)
    points[np.arange(p), np.arange(p)] = above
    points[p + np.arange(p), np.arange(p)] = below
    return points, above - below


def central_jacobian(residuals, point, lower=0.0, upper=1.0) -> np.ndarray:
    """(m, p): d r / d x of a batched residual function ``residuals`` ((n, p) points -> (n, m) rows) at
    ``point`` (p,) by central differences in the box (one call of 2 p points)."""
    point = np.asarray(point, dtype=float)
    points, steps = difference_points(point, lower, upper)
    rows = residuals(points)
    p = point.size
    return ((rows[:p] - rows[p:]) / steps[:, None]).T


TOLERANCE = 1e-10
"""least_squares' xtol, ftol and gtol of a calibration's fits."""


def box_least_squares(residuals, start, lower=0.0, upper=1.0, max_evaluations: int = 400,
                      tolerance: float = TOLERANCE):
    """scipy.optimize.least_squares (trust-region reflective) of a batched residual function ((n, p) points ->
    (n, m) rows) from ``start`` (p,) in the box [lower, upper] (scalars or (p,); infinite sides allowed), with the
    Jacobian by ``central_jacobian`` (module docstring), to ``tolerance`` (xtol, ftol and gtol); scipy's
    OptimizeResult."""
    start = np.clip(np.asarray(start, dtype=float), lower, upper)
    return least_squares(lambda x: residuals(x[None, :])[0], start,
                         jac=lambda x: central_jacobian(residuals, x, lower, upper), bounds=(lower, upper),
                         method="trf", x_scale="jac", xtol=tolerance, ftol=tolerance, gtol=tolerance,
                         max_nfev=max_evaluations)


def continued_least_squares(residuals, start, lower=0.0, upper=1.0, max_evaluations: int = 400,
                            continuations: int = 0, tolerance: float = TOLERANCE):
    """``box_least_squares`` restarted from where a run stopped on its budget of ``max_evaluations``, up to
    ``continuations`` times: (the last run's OptimizeResult, evaluations of every run, restarts made). The fit
    converged where the last run's status is positive (a tolerance met), not 0 (its budget spent)."""
    evaluations, restarts = 0, -1
    while True:
        solution = box_least_squares(residuals, start, lower, upper, max_evaluations, tolerance)
        evaluations, restarts, start = evaluations + int(solution.nfev), restarts + 1, solution.x
        if solution.status != 0 or restarts == continuations:
            return solution, evaluations, restarts


def jacobian(structure: Structure, space: FitSpace, unit, weight: float, solver: BackboneSolver = BackboneSolver()
             ) -> np.ndarray:
    """(2 levels, d + 1): d r / d u of the calibration's residual (``residual_rows``) by central differences."""
    return central_jacobian(lambda points: residual_rows(structure, space, points, weight, solver), unit)


class LocalFit(NamedTuple):
    """One weighted least-squares fit: the weight, the unit optimum (d + 1,), its design (d,) and zeta_0, the
    weighted chi^2, least_squares' status and message (of its last run), its evaluations (every run), whether it
    converged (status 1-4) and how many times it was restarted from where its budget stopped it."""

    weight: float
    unit: np.ndarray
    design: np.ndarray
    zeta0: float
    chi_squared: float
    status: int
    message: str
    evaluations: int
    converged: bool
    restarts: int


def local_fit(structure: Structure, space: FitSpace, start, weight: float = 0.5,
              solver: BackboneSolver = BackboneSolver(), max_evaluations: int = 400, continuations: int = 0,
              archive: FrontArchive | None = None) -> LocalFit:
    """Weighted least squares from the unit point ``start`` (d + 1,), ``max_evaluations`` per run, restarted from
    where a run stopped on that budget up to ``continuations`` times (module docstring); every point evaluated is
    offered to ``archive``."""
    solution, evaluations, restarts = continued_least_squares(
        lambda points: residual_rows(structure, space, points, weight, solver, archive), start,
        max_evaluations=max_evaluations, continuations=continuations)
    design, zeta0 = physical(space, solution.x)
    return LocalFit(weight, solution.x, design[0], float(zeta0[0]), float(2.0 * solution.cost), int(solution.status),
                    str(solution.message), evaluations, bool(solution.status > 0), restarts)


class Uncertainty(NamedTuple):
    """Parameter uncertainty at an optimum: the unit coordinates' standard deviations (d + 1,), the reduced chi^2
    (s^2), the physical uncertainty of each coordinate (a factor for log coordinates, an absolute value for
    linear ones, with ``kind`` "factor" or "absolute"; NaN where undetermined), and the names of the undetermined
    coordinates."""

    unit_std: np.ndarray
    reduced_chi_squared: float
    physical: np.ndarray
    kind: tuple[str, ...]
    undetermined: tuple[str, ...]


def uncertainty(structure: Structure, space: FitSpace, unit, solver: BackboneSolver = BackboneSolver()) -> Uncertainty:
    """The covariance of the unit coordinates at the optimum ``unit`` from the plain residual's Jacobian
    (module docstring)."""
    unit = np.asarray(unit, dtype=float)
    residual = residual_rows(structure, space, unit[None, :], 0.5, solver)[0]
    matrix = jacobian(structure, space, unit, 0.5, solver)
    dof = max(residual.size - unit.size, 1)
    reduced = float(residual @ residual / dof)
    covariance = reduced * np.linalg.pinv(matrix.T @ matrix, hermitian=True)
    unit_std = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    span = sampling_scale(space.upper, space.logarithmic) - sampling_scale(space.lower, space.logarithmic)
    determined = unit_std <= UNDETERMINED
    bounded = np.where(determined, unit_std, 0.0) * span
    physical_std = np.where(determined, np.where(space.logarithmic, np.exp(bounded), bounded), np.nan)
    undetermined = tuple(name for name, ok in zip(space.names, determined) if not ok)
    return Uncertainty(unit_std, reduced, physical_std,
                       tuple("factor" if log else "absolute" for log in space.logarithmic), undetermined)
