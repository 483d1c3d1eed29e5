"""A one-mode joint model: the measured mode as a linear oscillator plus hysteretic elements in parallel in its
modal coordinate (the modal Iwan form used in the field for measurements without a finite-element model behind
them).

In the mass-normalised modal coordinate q (m kg^0.5) the restoring force is

    F(q) = k_inf q + sum_j f_j(q),    k_inf = (1 - sum_j kappa_j) omega_0^2,    f_j'(0) = K_T,j = kappa_j omega_0^2,

with omega_0 the stuck (low-amplitude) natural frequency, kappa_j in (0, 1) the share of the stuck stiffness
element j carries, and f_j the backbone of a Jenkins or Iwan element (``nonlinear.slip_laws``, paper Eqs. 14-22)
with slip force F_S,j in modal force units (N kg^-0.5 per unit of m kg^0.5 times rad^2/s^2). One element is the
joint as one contact; a second one of the same law in parallel is a second group of contact patches that slips at
its own load (a joint whose patches carry very different normal loads has two slip stages). QSMA of this single
mode is closed form (paper Eqs. 23-25):

    omega(q)^2 = F(q) / q,    zeta_J(q) = sum_j D_j(q) / (2 pi q^2 omega(q)^2),

D_j element j's Masing dissipation per cycle at amplitude q (``slip_laws.masing_dissipation``).
"""

from __future__ import annotations

import numba
import numpy as np

from nonlinear import iwan, slip_laws

_LAW = ["float64(float64, float64, float64, float64, float64)"]
# ``nonlinear.slip_laws``' backbone force and Masing dissipation compiled as numpy ufuncs (the same expressions
# for one element at one scaled slip, broadcast like numpy's): a one-mode fit evaluates them on a few dozen
# amplitudes some 10^5 times, where numpy's dozen calls per law cost eight times the compiled loop. They equal the
# numpy forms to round-off: the powers round differently (numpy's vectorised power against libm's; measured in
# tests/nonlinear/test_friction_elements.py).
backbone_force = numba.vectorize(_LAW, cache=True)(slip_laws.backbone_force)
masing_dissipation = numba.vectorize(_LAW, cache=True)(slip_laws.masing_dissipation)


def element_backbone(amplitude, joint_stiffness: float, slip_force: float, chi: float | None = None,
                     beta: float = 0.0, theta: float = 1.0):
    """Restoring force (n,) and Masing dissipation per cycle (n,) of one element at modal amplitudes (n,)
    m kg^0.5 with stuck tangent ``joint_stiffness`` K_T and slip force F_S (modal units, module docstring). chi
    None: a Jenkins element (F_S, K_T); else an Iwan element (F_S, K_T, chi, beta) with stiction ratio theta
    (five-parameter form, paper Eq. 21)."""
    if chi is None:
        phi_max, r, s, chi = slip_force / joint_stiffness, 0.0, slip_force, -0.5
    else:
        phi_max, r, s = iwan.segalman_constants(slip_force, joint_stiffness, chi, beta)
    x = np.asarray(amplitude, dtype=float) / phi_max
    return backbone_force(x, r, s, chi, theta), 4.0 * phi_max * masing_dissipation(x, r, s, chi, theta)


def modal_joint_backbone(amplitude, stuck_frequency_hz: float, stiffness_fraction: float, slip_force: float,
                         chi: float | None = None, beta: float = 0.0, theta: float = 1.0, second_stage=None):
    """Natural frequency (Hz) and joint damping ratio at modal amplitudes (n,) m kg^0.5 of the one-mode model
    (module docstring). The joint's element: share kappa = ``stiffness_fraction``, ``slip_force``, and chi, beta,
    theta as in :func:`element_backbone`; ``second_stage``: None, or (kappa_2, F_S,2) of a second element of the
    same law (chi, beta, theta) in parallel. Returns (frequency_hz (n,), damping (n,))."""
    amplitude = np.asarray(amplitude, dtype=float)
    omega_squared_0 = (2.0 * np.pi * stuck_frequency_hz) ** 2
    elements = [(stiffness_fraction, slip_force)]
    if second_stage is not None:
        elements.append(second_stage)
    force = (1.0 - sum(element[0] for element in elements)) * omega_squared_0 * amplitude
    dissipation = np.zeros_like(amplitude)
    for kappa, element_slip_force in elements:
        element_force, element_dissipation = element_backbone(amplitude, kappa * omega_squared_0, element_slip_force,
                                                              chi, beta, theta)
        force = force + element_force
        dissipation = dissipation + element_dissipation
    omega_squared = force / amplitude
    return np.sqrt(omega_squared) / (2.0 * np.pi), dissipation / (2.0 * np.pi * amplitude ** 2 * omega_squared)
