"""A one-mode joint model: the measured mode as a linear oscillator plus one hysteretic element in its modal
coordinate (the modal Iwan form used in the field for measurements without a finite-element model behind them).

In the mass-normalised modal coordinate q (m kg^0.5) the restoring force is

    F(q) = k_inf q + f_J(q),    k_inf = (1 - kappa) omega_0^2,    f_J'(0) = K_T = kappa omega_0^2,

with omega_0 the stuck (low-amplitude) natural frequency, kappa in (0, 1) the share of the stuck stiffness the
joint carries, and f_J the backbone of a Jenkins or Iwan element (``nonlinear.slip_laws``, paper Eqs. 14-22)
with slip force F_S in modal force units (N kg^-0.5 per unit of m kg^0.5 times rad^2/s^2). QSMA of this single
mode is closed form (paper Eqs. 23-25):

    omega(q)^2 = F(q) / q,    zeta_J(q) = D(q) / (2 pi q^2 omega(q)^2),

D the element's Masing dissipation per cycle at amplitude q (``slip_laws.masing_dissipation``).
"""

from __future__ import annotations

import numpy as np

from nonlinear import iwan, slip_laws


def modal_joint_backbone(amplitude, stuck_frequency_hz: float, stiffness_fraction: float, slip_force: float,
                         chi: float | None = None, beta: float = 0.0, theta: float = 1.0):
    """Natural frequency (Hz) and joint damping ratio at modal amplitudes (n,) m kg^0.5 of the one-mode model
    (module docstring). chi None: a Jenkins element (F_S, K_T); else an Iwan element (F_S, K_T, chi, beta) with
    stiction ratio theta (five-parameter form, paper Eq. 21). Returns (frequency_hz (n,), damping (n,))."""
    amplitude = np.asarray(amplitude, dtype=float)
    omega_0 = 2.0 * np.pi * stuck_frequency_hz
    joint_stiffness = stiffness_fraction * omega_0 ** 2
    if chi is None:
        phi_max, r, s, chi = slip_force / joint_stiffness, 0.0, slip_force, -0.5
    else:
        phi_max, r, s = iwan.segalman_constants(slip_force, joint_stiffness, chi, beta)
    x = amplitude / phi_max
    force = (1.0 - stiffness_fraction) * omega_0 ** 2 * amplitude + slip_laws.backbone_force(x, r, s, chi, theta)
    omega_squared = force / amplitude
    dissipation = 4.0 * phi_max * slip_laws.masing_dissipation(x, r, s, chi, theta)
    return np.sqrt(omega_squared) / (2.0 * np.pi), dissipation / (2.0 * np.pi * amplitude ** 2 * omega_squared)
