"""Jenkins element: a linear spring K_T in series with a Coulomb slider of strength F_S (paper section 4.3.1).

All functions work on numpy arrays and broadcast over displacements and parameters. Displacements are the
amplitude of the relative tangential motion of a patch pair (m), forces in N, stiffnesses in N/m, dissipation
in J per cycle.
"""

from __future__ import annotations

import numpy as np

from nonlinear import slip_laws
from nonlinear.parameters import check_jenkins


def backbone(displacement, stiffness, slip_force):
    """Backbone force f(u) of a Jenkins element, paper Eq. (14): K_T u up to F_S, then F_S.

    Odd in u (the Masing backbone of a symmetric element).
    """
    check_jenkins(stiffness, slip_force)
    u = np.asarray(displacement, dtype=float)
    return np.sign(u) * np.minimum(stiffness * np.abs(u), slip_force)


def tangent(displacement, stiffness, slip_force):
    """Tangent stiffness df/du of the backbone (N/m): K_T while stuck, 0 once slipping."""
    check_jenkins(stiffness, slip_force)
    u = np.asarray(displacement, dtype=float)
    return np.where(stiffness * np.abs(u) < slip_force, stiffness, 0.0)


def slip_deficit(displacement, stiffness, slip_force):
    """Force lost to slip, K_T u - f(u) (N): zero while stuck, K_T u - F_S once slipping
    (``nonlinear.slip_laws`` with r = 0, s = F_S, phi_max = F_S / K_T)."""
    check_jenkins(stiffness, slip_force)
    x = np.asarray(displacement, dtype=float) * stiffness / slip_force
    return slip_laws.slip_deficit(x, 0.0, slip_force, -0.5, 1.0)


def slip_deficit_tangent(displacement, stiffness, slip_force):
    """Derivative of the slip deficit (N/m): 0 while stuck, K_T once slipping."""
    check_jenkins(stiffness, slip_force)
    x = np.asarray(displacement, dtype=float) * stiffness / slip_force
    return slip_laws.slip_deficit_slope(x, 0.0, slip_force, -0.5, 1.0) * stiffness / slip_force


def slip_deficit_potential(displacement, stiffness, slip_force):
    """Integral of the slip deficit from 0 to u (J): K_T (|u| - F_S/K_T)^2 / 2 once slipping. Convex."""
    check_jenkins(stiffness, slip_force)
    x = np.asarray(displacement, dtype=float) * stiffness / slip_force
    return slip_laws.slip_deficit_potential(x, 0.0, slip_force, -0.5, 1.0) * slip_force / stiffness


def dissipation(amplitude, stiffness, slip_force):
    """Energy dissipated per steady cycle of amplitude u0 (J), paper Eq. (15): 4 F_S (u0 - F_S/K_T) once slipping."""
    check_jenkins(stiffness, slip_force)
    u0 = np.abs(np.asarray(amplitude, dtype=float))
    return 4.0 * slip_force * np.maximum(u0 - slip_force / stiffness, 0.0)


def describing_function(amplitude, stiffness, slip_force):
    """First-harmonic (describing-function) stiffnesses of a Jenkins element under u = u0 cos(tau) (N/m):
    f(tau) ~ K_eq u0 cos(tau) - K_D u0 sin(tau) = K_eq u + (K_D / omega) du/dt.

    Derivation: from the reversal at u0 the force falls along f = F_S - K_T u0 (1 - cos tau) until it reaches
    -F_S at tau = beta, cos(beta) = 1 - 2 F_S / (K_T u0), then slides at -F_S up to tau = pi (half-wave symmetry
    gives the other half). The Fourier coefficients (2/pi) int_0^pi f cos and (2/pi) int_0^pi f sin give

        K_eq = K_T (beta - sin(2 beta) / 2) / pi,     K_D = D / (pi u0^2),   D = 4 F_S (u0 - F_S / K_T),

    D the dissipation per cycle (paper Eq. 15). Stuck (K_T u0 <= F_S): K_eq = K_T, K_D = 0. A mass m on a spring
    k in parallel with the element then has the single-harmonic backbone omega^2 = (k + K_eq) / m and damping
    ratio zeta = K_D / (2 m omega^2) = D / (2 pi m omega^2 u0^2).
    """
    check_jenkins(stiffness, slip_force)
    u0 = np.abs(np.asarray(amplitude, dtype=float))
    beta = np.arccos(np.clip(1.0 - 2.0 * slip_force / (stiffness * u0), -1.0, 1.0))
    equivalent = stiffness * (beta - np.sin(2.0 * beta) / 2.0) / np.pi
    return equivalent, dissipation(u0, stiffness, slip_force) / (np.pi * u0 ** 2)
