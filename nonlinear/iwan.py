"""Segalman's four-parameter Iwan element and its five-parameter stiction extension (paper 4.3.2-4.3.3).

The element is a continuum of parallel unit-stiffness Jenkins elements whose slip displacements phi follow
rho(phi) = R phi^chi on (0, phi_max) plus a spike S delta(phi - phi_max) (paper Eq. 16). It is specified by
the physical parameters

    F_S  macroslip force (N), K_T  initial tangent stiffness (N/m),
    chi  exponent in (-1, 0), beta = S (chi+1) / (R phi_max^(chi+1))  spike-to-continuum stiffness ratio (>= 0),
    theta  (five-parameter model) dynamic-to-static slider strength ratio in [0, 1] (Eq. 20),

mapped to (phi_max, R, S) by Segalman's relations (docs/design.md section 5). R reaches 1e37 inside Table 3, so
every law here is written in the scaled slip x = u / phi_max with the scaled constants

    r = R phi_max^(chi + 2)  (N),   s = S phi_max  (N),

which stay of the order of F_S. Forces are in N, displacements in m, dissipation in J per cycle. All
functions broadcast over displacements and parameters.
"""

from __future__ import annotations

import numpy as np

from nonlinear import slip_laws
from nonlinear.parameters import check_iwan


def segalman_constants(slip_force, stiffness, chi, beta):
    """Segalman's mapping (F_S, K_T, chi, beta) -> (phi_max, r, s) in scaled form.

    phi_max = F_S (1 + beta) / (K_T (beta + (chi+1)/(chi+2)))   (m)
    r = R phi_max^(chi+2) = F_S (chi+1) / (beta + (chi+1)/(chi+2))   (N)
    s = S phi_max = beta r / (chi+1)   (N)
    so that the macroslip force s + r/(chi+2) equals F_S and the initial tangent (s + r/(chi+1))/phi_max
    equals K_T.
    """
    check_iwan(slip_force, stiffness, chi, beta)
    return scaled_constants(slip_force, stiffness, chi, beta)


def scaled_constants(slip_force, stiffness, chi, beta):
    """Segalman's mapping (``segalman_constants``) without the parameters' check: arithmetic only, so that it
    evaluates numpy arrays and compiles with numba for scalars (inside a kernel whose caller checked them)."""
    shape_factor = beta + (chi + 1.0) / (chi + 2.0)
    phi_max = slip_force * (1.0 + beta) / (stiffness * shape_factor)
    r = slip_force * (chi + 1.0) / shape_factor
    s = beta * r / (chi + 1.0)
    return phi_max, r, s


def four_parameter_backbone(displacement, slip_force, stiffness, chi, beta):
    """Backbone f(u) of the four-parameter Iwan element (N), paper Eq. (18), odd in u."""
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    u = np.asarray(displacement, dtype=float)
    x = np.abs(u) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = (s + r / (chi + 1.0)) * xm - r * xm ** (chi + 2.0) / ((chi + 1.0) * (chi + 2.0))
    return np.sign(u) * np.where(x < 1.0, microslip, s + r / (chi + 2.0))


def four_parameter_tangent(displacement, slip_force, stiffness, chi, beta):
    """Tangent df/du of the four-parameter backbone (N/m): K_T at u = 0, falling to S at phi_max, then 0."""
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.abs(np.asarray(displacement, dtype=float)) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = (s + r * (1.0 - xm ** (chi + 1.0)) / (chi + 1.0)) / phi_max
    return np.where(x < 1.0, microslip, 0.0)


def four_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta):
    """Energy dissipated per Masing cycle of amplitude u0 (J), paper Eq. (19).

    Microslip (u0 < phi_max): 4 R u0^(chi+3) / ((chi+2)(chi+3)), the power law of exponent chi + 3.
    """
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.abs(np.asarray(amplitude, dtype=float)) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = 4.0 * r * phi_max * xm ** (chi + 3.0) / ((chi + 2.0) * (chi + 3.0))
    macroslip = 4.0 * r * phi_max * (x / (chi + 2.0) - 1.0 / (chi + 3.0)) + 4.0 * s * phi_max * (x - 1.0)
    return np.where(x < 1.0, microslip, macroslip)


def four_parameter_slip_deficit(displacement, slip_force, stiffness, chi, beta):
    """Force lost to slip, K_T u - f(u) (N), odd in u; microslip: R u^(chi+2) / ((chi+1)(chi+2)).

    The closed form avoids the cancellation of K_T u against f(u) at small amplitude, where QSMA needs it.
    """
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    return slip_laws.slip_deficit(np.asarray(displacement, dtype=float) / phi_max, r, s, chi, 1.0)


def four_parameter_slip_deficit_tangent(displacement, slip_force, stiffness, chi, beta):
    """Derivative of the four-parameter slip deficit (N/m): R u^(chi+1) / (chi+1) in microslip, K_T beyond."""
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.asarray(displacement, dtype=float) / phi_max
    return slip_laws.slip_deficit_slope(x, r, s, chi, 1.0) / phi_max


def four_parameter_slip_deficit_potential(displacement, slip_force, stiffness, chi, beta):
    """Integral of the four-parameter slip deficit from 0 to u (J); convex (its derivative, the deficit,
    increases with |u|). Microslip: R u^(chi+3) / ((chi+1)(chi+2)(chi+3))."""
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.asarray(displacement, dtype=float) / phi_max
    return phi_max * slip_laws.slip_deficit_potential(x, r, s, chi, 1.0)


def five_parameter_backbone(displacement, slip_force, stiffness, chi, beta, theta):
    """Backbone f(u) of the five-parameter (stiction) Iwan element (N), paper Eq. (21), odd in u.

    Slipped sliders carry theta times their static strength, so the backbone drops by s (1 - theta) when the
    spike of sliders at phi_max breaks loose, and saturates at theta F_S.
    """
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    u = np.asarray(displacement, dtype=float)
    x = np.abs(u) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = (s + r / (chi + 1.0)) * xm + r * xm ** (chi + 2.0) * (theta / (chi + 2.0) - 1.0 / (chi + 1.0))
    return np.sign(u) * np.where(x < 1.0, microslip, theta * (s + r / (chi + 2.0)))


def five_parameter_tangent(displacement, slip_force, stiffness, chi, beta, theta):
    """Tangent df/du of the five-parameter backbone (N/m); negative near phi_max when theta is small."""
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.abs(np.asarray(displacement, dtype=float)) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = (s + r / (chi + 1.0) + r * xm ** (chi + 1.0) * (theta - (chi + 2.0) / (chi + 1.0))) / phi_max
    return np.where(x < 1.0, microslip, 0.0)


def five_parameter_slip_deficit(displacement, slip_force, stiffness, chi, beta, theta):
    """Force lost to slip, K_T u - f(u) (N), odd in u; microslip: R u^(chi+2) (1/(chi+1) - theta/(chi+2))."""
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    return slip_laws.slip_deficit(np.asarray(displacement, dtype=float) / phi_max, r, s, chi, theta)


def five_parameter_slip_deficit_tangent(displacement, slip_force, stiffness, chi, beta, theta):
    """Derivative of the five-parameter slip deficit (N/m): R u^(chi+1) ((chi+2)/(chi+1) - theta) in microslip."""
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.asarray(displacement, dtype=float) / phi_max
    return slip_laws.slip_deficit_slope(x, r, s, chi, theta) / phi_max


def five_parameter_slip_deficit_potential(displacement, slip_force, stiffness, chi, beta, theta):
    """Integral of the five-parameter slip deficit from 0 to u (J). Not convex for theta < 1: the
    stiction drop makes the deficit jump up at phi_max and the backbone can soften faster than K_T."""
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.asarray(displacement, dtype=float) / phi_max
    return phi_max * slip_laws.slip_deficit_potential(x, r, s, chi, theta)


def five_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta, theta):
    """Energy dissipated per Masing cycle of amplitude u0 (J), paper Eq. (22).

    Microslip: 4 R u0^(chi+3) (chi (1 - theta) + 2 - theta) / ((chi+2)(chi+3)); each slipped slider of
    strength phi dissipates 4 theta phi (u0 - (2 theta - 1) phi / theta).
    """
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    x = np.abs(np.asarray(amplitude, dtype=float)) / phi_max
    xm = np.minimum(x, 1.0)
    microslip = (4.0 * r * phi_max * xm ** (chi + 3.0) * (chi * (1.0 - theta) + 2.0 - theta)
                 / ((chi + 2.0) * (chi + 3.0)))
    macroslip = (4.0 * r * phi_max * (theta * x / (chi + 2.0) - (2.0 * theta - 1.0) / (chi + 3.0))
                 + 4.0 * s * phi_max * (theta * x - (2.0 * theta - 1.0)))
    return np.where(x < 1.0, microslip, macroslip)
