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

D_j element j's Masing dissipation per cycle at amplitude q (``slip_laws.masing_dissipation``). A fit evaluates
it some 10^5 times on a few dozen amplitudes, so it is one compiled kernel (numba) of the same scalar expressions
as the laws' numpy forms (equal to them to round-off: numpy's vectorised powers round differently from libm's).
"""

from __future__ import annotations

import numba
import numpy as np

from nonlinear import iwan, slip_laws
from nonlinear.parameters import check_iwan, check_jenkins, check_stiction_ratio, in_range

# Segalman's mapping and ``nonlinear.slip_laws``' backbone force and Masing dissipation compiled for scalars: the
# same expressions as their numpy forms (one law for every element, ``nonlinear.slip_laws``).
_scaled_constants = numba.njit(iwan.scaled_constants, cache=True, error_model="numpy")
_backbone_force = numba.njit(slip_laws.backbone_force, cache=True, error_model="numpy")
_masing_dissipation = numba.njit(slip_laws.masing_dissipation, cache=True, error_model="numpy")
_in_range = numba.njit(in_range, cache=True)


@numba.njit(cache=True, error_model="numpy")
def _element(amplitude, joint_stiffness, slip_force, chi, beta, theta, iwan):
    """Restoring force and Masing dissipation per cycle of one element at a modal amplitude (module docstring):
    an Iwan element (Segalman's mapping) where ``iwan``, else a Jenkins one (r = 0, s = F_S, phi_max = F_S / K_T,
    chi and beta unused)."""
    if iwan:
        phi_max, r, s = _scaled_constants(slip_force, joint_stiffness, chi, beta)
    else:
        phi_max, r, s, chi = slip_force / joint_stiffness, 0.0, slip_force, -0.5
    x = amplitude / phi_max
    return (_backbone_force(x, r, s, chi, theta),
            4.0 * phi_max * _masing_dissipation(x, r, s, chi, theta))


@numba.guvectorize(["void(float64, float64, float64, float64, float64, float64, float64, float64, float64, "
                    "boolean, boolean, float64[:], float64[:], boolean[:])"],
                   "(),(),(),(),(),(),(),(),(),(),()->(),(),()", cache=True)
def _one_mode_backbone(amplitude, omega_squared_0, kappa, slip_force, kappa_2, slip_force_2, chi, beta, theta,
                       iwan, second, frequency, damping, parameters_in_range):
    """Natural frequency (Hz) and joint damping at one amplitude (module docstring's omega(q)^2 and zeta_J(q)):
    the joint's element (kappa, F_S) and, where ``second``, the second one (kappa_2, F_S,2), of Iwan's law where
    ``iwan``, else of Jenkins', and whether their parameters lie in their ranges (``nonlinear.parameters.in_range``;
    where they do not, NaN, computing nothing); a numpy ufunc (broadcast like one) with three outputs."""
    joint_stiffness = kappa * omega_squared_0
    joint_stiffness_2 = kappa_2 * omega_squared_0 if second else 0.0
    parameters_in_range[0] = _in_range(slip_force, joint_stiffness, chi, beta, theta, iwan) and (
        not second or _in_range(slip_force_2, joint_stiffness_2, chi, beta, theta, iwan))
    if not parameters_in_range[0]:
        frequency[0], damping[0] = np.nan, np.nan
        return
    force = (1.0 - (kappa + kappa_2 if second else kappa)) * omega_squared_0 * amplitude
    element_force, dissipation = _element(amplitude, joint_stiffness, slip_force, chi, beta, theta, iwan)
    force += element_force
    if second:
        element_force, element_dissipation = _element(amplitude, joint_stiffness_2, slip_force_2, chi, beta, theta,
                                                      iwan)
        force += element_force
        dissipation += element_dissipation
    omega_squared = force / amplitude
    frequency[0] = np.sqrt(omega_squared) / (2.0 * np.pi)
    damping[0] = dissipation / (2.0 * np.pi * amplitude ** 2 * omega_squared)


def modal_joint_backbone(amplitude, stuck_frequency_hz: float, stiffness_fraction: float, slip_force: float,
                         chi: float | None = None, beta: float = 0.0, theta: float = 1.0, second_stage=None):
    """Natural frequency (Hz) and joint damping ratio at modal amplitudes (n,) m kg^0.5 of the one-mode model
    (module docstring). The joint's element: share kappa = ``stiffness_fraction``, slip force F_S (modal units);
    chi None: a Jenkins element (F_S, K_T = kappa omega_0^2), else an Iwan element (F_S, K_T, chi, beta) with
    stiction ratio theta (five-parameter form, paper Eq. 21); ``second_stage``: None, or (kappa_2, F_S,2) of a
    second element of the same law (chi, beta, theta) in parallel. The parameters broadcast against the amplitudes
    like numpy's (rows of parameters (b, 1) give (b, n)). Returns (frequency_hz, damping);
    ``nonlinear.parameters.FrictionParameterError`` where an element's parameters leave their ranges."""
    omega_squared_0 = (2.0 * np.pi * np.asarray(stuck_frequency_hz, dtype=float)) ** 2
    kappa_2, slip_force_2 = (0.0, 1.0) if second_stage is None else second_stage
    frequency, damping, parameters_in_range = _one_mode_backbone(
        amplitude, omega_squared_0, stiffness_fraction, slip_force, kappa_2, slip_force_2,
        -0.5 if chi is None else chi, beta, theta, chi is not None, second_stage is not None)
    if parameters_in_range.size == 0 or not parameters_in_range.all():  # no amplitude: the checks all the same
        for kappa, element_slip_force in [(stiffness_fraction, slip_force)] + ([] if second_stage is None
                                                                               else [second_stage]):
            stiffness = kappa * omega_squared_0
            if chi is None:
                check_jenkins(stiffness, element_slip_force)
                check_stiction_ratio(theta)
            else:
                check_iwan(element_slip_force, stiffness, chi, beta, theta)
    return frequency, damping


def slip_amplitudes(stuck_frequency_hz, stiffness_fraction, slip_force, chi: float | None = None, beta=0.0,
                    second_stage=None) -> list:
    """Modal amplitudes phi_max (m kg^0.5) at which the elements of ``modal_joint_backbone`` (the joint's, then the
    second stage's; its arguments) slip whole: F_S / K_T for Jenkins, Segalman's phi_max for Iwan
    (``iwan.scaled_constants``). There a stiction ratio theta < 1 drops the element's force by s (1 - theta)
    (``slip_laws.backbone_force`` at |x| = 1): the backbone jumps. Arithmetic: arrays of parameters give arrays."""
    omega_squared_0 = (2.0 * np.pi * np.asarray(stuck_frequency_hz, dtype=float)) ** 2
    elements = [(stiffness_fraction, slip_force)] + ([] if second_stage is None else [second_stage])
    return [element_slip_force / (kappa * omega_squared_0) if chi is None
            else iwan.scaled_constants(element_slip_force, kappa * omega_squared_0, chi, beta)[0]
            for kappa, element_slip_force in elements]
