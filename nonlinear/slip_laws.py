"""The force a Masing element loses to slip, its backbone force and its Masing dissipation, in scaled form,
without branches: one law for every element.

For an Iwan element (paper Eq. 16, five-parameter form Eq. 21) in the scaled slip x = u / phi_max with the
scaled constants r = R phi_max^(chi+2) and s = S phi_max (N, ``nonlinear.iwan.segalman_constants``), the
slip deficit g = K_T u - f(u) is

    |x| < 1:  r |x|^(chi+2) (1/(chi+1) - theta/(chi+2))
    |x| > 1:  g(1-) + (s + r/(chi+1)) (|x| - 1) + s (1 - theta)      (the spike's stiction drop),

odd in x. A Jenkins element is the same law with r = 0, s = F_S and phi_max = F_S / K_T (all its stiffness
in the spike); a stuck (linear) element has r = s = 0. The backbone force f = K_T u - g, its slope and the
Masing dissipation D = 4 phi_max (x g - 2 G) (G the integral of g; paper Eqs. 15, 19, 22) follow from g with
K_T phi_max = s + r/(chi+1), each written as a sum of terms of one sign where the law allows (no cancellation
of K_T u against g beyond macroslip, none of x g against 2 G in deep macroslip). The expressions use only
min, max, powers and comparisons, so the same functions evaluate numpy arrays and compile with numba for
scalars. At |x| = 1 exactly the stiction drop has not happened yet (the static peak), in every function.
"""

from __future__ import annotations

import numpy as np


def slip_deficit(x, r, s, chi, theta):
    """Slip deficit K_T u - f(u) (N) at scaled slip x."""
    a = np.abs(x)
    xm = np.minimum(a, 1.0)
    beyond = np.maximum(a - 1.0, 0.0)
    microslip = r * xm ** (chi + 2.0) * (1.0 / (chi + 1.0) - theta / (chi + 2.0))
    return np.sign(x) * (microslip + (s + r / (chi + 1.0)) * beyond + s * (1.0 - theta) * (a > 1.0))


def slip_deficit_slope(x, r, s, chi, theta):
    """d(slip deficit)/dx (N per unit scaled slip); divide by phi_max for N/m. Between 0 (stuck) and
    s + r/(chi+1) = K_T phi_max (macroslip); above it where a stiction backbone softens (theta < 1)."""
    a = np.abs(x)
    microslip = r * np.minimum(a, 1.0) ** (chi + 1.0) * ((chi + 2.0) / (chi + 1.0) - theta)
    return (a < 1.0) * microslip + (a >= 1.0) * (s + r / (chi + 1.0))


def slip_deficit_potential(x, r, s, chi, theta):
    """Integral of the slip deficit from 0 to x (N per unit scaled slip); multiply by phi_max for J."""
    a = np.abs(x)
    xm = np.minimum(a, 1.0)
    beyond = np.maximum(a - 1.0, 0.0)
    at_macroslip = r * (1.0 / (chi + 1.0) - theta / (chi + 2.0)) + s * (1.0 - theta)
    return (r * (1.0 / (chi + 1.0) - theta / (chi + 2.0)) * xm ** (chi + 3.0) / (chi + 3.0)
            + at_macroslip * beyond + (s + r / (chi + 1.0)) * beyond ** 2 / 2.0)


def backbone_force(x, r, s, chi, theta):
    """Backbone force f = K_T u - g(u) (N) at scaled slip x, odd in x:

        |x| <= 1:  s |x| + r |x| (1 - |x|^(chi+1)) / (chi+1) + r theta |x|^(chi+2) / (chi+2)   (terms >= 0)
        |x| > 1:   theta (s + r/(chi+2)) = theta F_S,   constant (no K_T u - g cancellation).
    """
    a = np.abs(x)
    xm = np.minimum(a, 1.0)
    microslip = s * xm + r * xm * (1.0 - xm ** (chi + 1.0)) / (chi + 1.0) + r * theta * xm ** (chi + 2.0) / (chi + 2.0)
    return np.sign(x) * ((a <= 1.0) * microslip + (a > 1.0) * theta * (s + r / (chi + 2.0)))


def backbone_force_slope(x, r, s, chi, theta):
    """d(backbone force)/dx = K_T phi_max - d(slip deficit)/dx (N per unit scaled slip; divide by phi_max for
    N/m): K_T phi_max = s + r/(chi+1) stuck, falling to s - r (1 - theta) at macroslip, exactly 0 beyond;
    negative near macroslip where a stiction backbone softens."""
    a = np.abs(x)
    power = np.minimum(a, 1.0) ** (chi + 1.0)
    return (a < 1.0) * (s + r * (1.0 - power) / (chi + 1.0) - r * (1.0 - theta) * power)


def masing_dissipation(x, r, s, chi, theta):
    """x g(x) - 2 G(x) (N per unit scaled slip) at the amplitude x; times 4 phi_max, the energy dissipated per
    Masing cycle (J). From the slip deficit's law, as a sum of terms >= 0:

        |x| <= 1:  r (1/(chi+1) - theta/(chi+2)) (chi+1)/(chi+3) |x|^(chi+3)     (power law of exponent chi+3)
        |x| > 1:   that at 1, + s (1 - theta) (the stiction drop), + theta (s + r/(chi+2)) (|x| - 1).
    """
    a = np.abs(x)
    xm = np.minimum(a, 1.0)
    beyond = np.maximum(a - 1.0, 0.0)
    microslip = r * (1.0 / (chi + 1.0) - theta / (chi + 2.0)) * (chi + 1.0) / (chi + 3.0) * xm ** (chi + 3.0)
    return microslip + s * (1.0 - theta) * (a > 1.0) + theta * (s + r / (chi + 2.0)) * beyond

