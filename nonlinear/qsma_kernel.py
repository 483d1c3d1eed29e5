"""Compiled (numba) solver of the condensed static QSMA problem, design by design and level by level.

For one design the unknowns are the 2 n_patches tangential joint translations in scaled form,
x_i = r_i / phi_max_i, and the equations (``nonlinear.qsma``) are

    R(x) = r - linear - C g(r) = 0,   g the slip deficits (``nonlinear.slip_laws``),

the stationarity condition of the potential energy E(r) = (r - linear)^T C^+ (r - linear) / 2 - sum G_i(r_i),
convex for the Jenkins and four-parameter Iwan laws (DESIGN.md section 5.1). Newton's step uses the slope of
g clipped at K_T (which only changes stiction backbones that soften, keeping the Newton matrix positive
semi-definite so the step descends E towards a stable state); its length is halved until E decreases
enough (Armijo) or, once E differences reach round-off, until |R| decreases. Levels are solved in order,
each starting from the last converged one (continuation).
"""

from __future__ import annotations

import numba
import numpy as np

from nonlinear import slip_laws
from nonlinear.stuck_modes import solve_dense

# Status codes per design and level; UNRESTRAINED: no solution, and every loaded slipping element is beyond
# macroslip (or the Newton matrix is singular): the halves slide freely.
CONVERGED, NOT_CONVERGED, UNRESTRAINED = 0, 1, 2
TARGET_TOLERANCE = 1e-14  # iterate until max|R| / (largest term of R) is below this ...
ACCEPT_TOLERANCE = 1e-10  # ... or stalls; accept below this (the oracle's criterion)
MAX_ITERATIONS = 60
MAX_HALVINGS = 40

_deficit = numba.njit(cache=True)(slip_laws.slip_deficit)
_slope = numba.njit(cache=True)(slip_laws.slip_deficit_slope)
_potential = numba.njit(cache=True)(slip_laws.slip_deficit_potential)


@numba.njit(cache=True)
def _residual(x, linear, compliance, phi, r, s, chi, theta, out):
    """Scaled residual R / phi into ``out``; returns max|R| over the largest term (round-off floor ~1e-16)."""
    m = x.size
    g = np.empty(m)
    for i in range(m):
        g[i] = _deficit(x[i], r[i], s[i], chi[i], theta[i])
    largest_residual, largest_term = 0.0, 1e-300
    for i in range(m):
        slip_term = 0.0
        for j in range(m):
            slip_term += compliance[i, j] * g[j]
        residual = x[i] * phi[i] - linear[i] - slip_term
        out[i] = residual / phi[i]
        largest_residual = max(largest_residual, abs(residual))
        largest_term = max(largest_term, abs(x[i] * phi[i]), abs(linear[i]), abs(slip_term))
    return largest_residual / largest_term


@numba.njit(cache=True)
def _energy(x, linear, compliance_pinv, phi, r, s, chi, theta):
    """Potential energy E (J) and the magnitude of its terms (for its round-off)."""
    m = x.size
    quadratic, potential = 0.0, 0.0
    for i in range(m):
        excess_i = x[i] * phi[i] - linear[i]
        for j in range(m):
            quadratic += 0.5 * excess_i * compliance_pinv[i, j] * (x[j] * phi[j] - linear[j])
        potential += phi[i] * _potential(x[i], r[i], s[i], chi[i], theta[i])
    return quadratic - potential, abs(quadratic) + abs(potential)


@numba.njit(cache=True)
def _newton(x, linear, compliance, compliance_pinv, phi, r, s, chi, theta):
    """Damped Newton for one design at one level from x; returns (x, status)."""
    m = x.size
    x = x.copy()
    residual = np.empty(m)
    trial_residual = np.empty(m)
    error = _residual(x, linear, compliance, phi, r, s, chi, theta, residual)
    jacobian = np.empty((m, m))
    singular = False
    for _ in range(MAX_ITERATIONS):
        if error <= TARGET_TOLERANCE:
            break
        for j in range(m):
            clipped = min(_slope(x[j], r[j], s[j], chi[j], theta[j]), s[j] + r[j] / (chi[j] + 1.0))
            for i in range(m):
                jacobian[i, j] = (1.0 if i == j else 0.0) - compliance[i, j] * clipped / phi[i]
        step, singular = solve_dense(jacobian, -residual)
        if singular:
            break
        energy, energy_terms = _energy(x, linear, compliance_pinv, phi, r, s, chi, theta)
        descent, norm = 0.0, 0.0
        for i in range(m):
            norm += residual[i] ** 2
            for j in range(m):
                descent += step[i] * phi[i] * compliance_pinv[i, j] * residual[j] * phi[j]
        norm = np.sqrt(norm)
        length = 1.0
        accepted = False
        for _ in range(MAX_HALVINGS):
            trial = x + length * step
            trial_error = _residual(trial, linear, compliance, phi, r, s, chi, theta, trial_residual)
            trial_energy, _ = _energy(trial, linear, compliance_pinv, phi, r, s, chi, theta)
            armijo = trial_energy <= energy + 1e-4 * length * min(descent, 0.0)
            smaller = (np.sqrt(np.sum(trial_residual ** 2)) < (1.0 - 1e-4 * length) * norm
                       and trial_energy <= energy + 1e-12 * energy_terms)
            if armijo or smaller:
                x, error, accepted = trial, trial_error, True
                residual[:] = trial_residual
                break
            length *= 0.5
        if not accepted:
            break
    if error <= ACCEPT_TOLERANCE:
        return x, CONVERGED
    beyond_macroslip = True
    for i in range(m):
        if (r[i] > 0.0 or s[i] > 0.0) and linear[i] != 0.0 and abs(x[i]) < 1.0:
            beyond_macroslip = False
    return x, UNRESTRAINED if singular or beyond_macroslip else NOT_CONVERGED


@numba.njit(cache=True)
def solve_levels(levels, linear_per_level, compliance, compliance_pinv, phi, r, s, chi, theta):
    """All designs, all levels. linear_per_level: (n_designs, m), the linear joint motion per unit level;
    compliance, compliance_pinv: (n_designs, m, m); phi, r, s, chi, theta: (n_designs, m) slip-law
    constants. Returns scaled solutions (n_designs, levels, m), NaN where not converged, and status codes."""
    n_designs, m = linear_per_level.shape
    solutions = np.full((n_designs, levels.size, m), np.nan)
    status = np.full((n_designs, levels.size), NOT_CONVERGED, dtype=np.int8)
    for d in range(n_designs):
        x = linear_per_level[d] * levels[0] / phi[d]
        for level in range(levels.size):
            x_level, code = _newton(x, linear_per_level[d] * levels[level], compliance[d], compliance_pinv[d],
                                    phi[d], r[d], s[d], chi[d], theta[d])
            status[d, level] = code
            if code == CONVERGED:
                solutions[d, level] = x_level
                x = x_level
    return solutions, status
