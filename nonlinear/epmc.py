"""The extended periodic motion concept (EPMC; Krack, "Nonlinear modal analysis of nonconservative systems:
extension of the periodic motion concept", Computers & Structures 154, 2015): the amplitude-dependent nonlinear
mode of the jointed structure, by harmonic balance in its condensed joint space (``nonlinear.harmonic_balance``).

The mode's damping enters as a negative mass-proportional viscous term -xi M eta' that feeds back what the joint
dissipates, so that the damped structure has a periodic motion at every amplitude; xi = 2 zeta omega gives the
modal damping ratio zeta. The motion is normalised by its modal coordinate: the fundamental harmonic of the stuck
target mode's coordinate p = v_target^T eta (the mass-normalised modal amplitude QSMA also prescribes, q =
phi_0^T M u) is q cos(omega t): amplitude q, phase zero (no sine part). Harmonic 1 of the target's equation then
gives omega and xi,

    (mu_0 - omega^2) q = b^T G_a1,      omega xi q = b^T G_b1,     b = c_target,

and the other harmonics and modes give the joint motion (``nonlinear.harmonic_balance`` module docstring):

    U_a1 = q b + Hd'_1 G_a1 + He'_1 G_b1,   U_b1 = Hd'_1 G_b1 - He'_1 G_a1   (' : without the target mode),
    U_ak, U_bk (k != 1) and U_0 = Hd_0 G_0 + C load   with every mode.

Unknowns, scaled for the continuation in lambda = ln q: y = (U / q, omega / omega_0, xi / omega_0), residuals
divided by q (joint rows) and mu_0 q (the target's two). Stuck (no slider slides) the solution is the linear mode:
G = 0, omega = omega_0, xi = 0. The number of harmonics is chosen by ``converged_harmonics``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.condensation import JointSpace
from nonlinear.harmonic_balance import (JointHarmonics, JointSystem, compliance_operator, dynamic_compliance,
                                        element_jacobian, harmonic_count, modal_harmonics, newton, pseudo_arclength,
                                        stacked_sliders)
from nonlinear.friction_models import SMALLEST_SLIDER
from nonlinear.joint import (patch_elements, slip_displacement, stuck_stiffness, tangential_dissipation,
                             tangential_elements, tangential_rows)
from nonlinear.qsma import qsma_reference, stuck_target_mode

HARMONICS = (1, 3, 5, 7, 9, 11, 15)  # harmonic counts tried by ``converged_harmonics``, in order
SAMPLES = 256  # samples per period of the AFT time loop
FREQUENCY_TOLERANCE = 1e-5  # converged_harmonics: relative change of omega between two harmonic counts
DAMPING_TOLERANCE = 1e-3  # converged_harmonics: relative change of zeta between two harmonic counts
RESOLUTION = 1e-2  # slider_resolution: smallest slider slip displacement per slip ratio reached
SMALLEST_RESOLVED = 1e-16  # slider_resolution: floor of the smallest slider slip displacement (units of phi_max)
RELEVANT_DISSIPATION = 1e-6  # slider_resolution: share of the dissipation from which an element is resolved


def slider_resolution(slip_ratio, dissipation) -> np.ndarray:
    """The smallest slip displacement (units of phi_max) each element's Iwan sliders must resolve
    (``FrictionModel.sliders``), from its slip ratio x_e (n_t,) at the lowest amplitude asked and its Masing
    dissipation there (n_t,) J: RESOLUTION x_e, within [SMALLEST_RESOLVED, SMALLEST_SLIDER], for the elements
    that dissipate at least RELEVANT_DISSIPATION of the total; SMALLEST_SLIDER for the others.

    Why: the sliders lump every slip displacement below the smallest into one slider; an element cycling at an
    amplitude below it dissipates nothing, and one at a few times it too much (a 4-parameter Iwan element with
    chi = -0.4 at 1.4e-4 phi_max: +25 %; below 4e-5 phi_max: nothing). From 100 times the smallest up the
    sliders' Masing dissipation is within about 1e-5 of the closed form (``nonlinear.slip_laws``)."""
    slip_ratio, dissipation = np.asarray(slip_ratio, dtype=float), np.asarray(dissipation, dtype=float)
    resolved = np.clip(RESOLUTION * slip_ratio, SMALLEST_RESOLVED, SMALLEST_SLIDER)
    relevant = dissipation >= RELEVANT_DISSIPATION * dissipation.sum()
    return np.where(relevant, resolved, SMALLEST_SLIDER)


def joint_system(space: JointSpace, model: str, design, stuck_group: int | None = None,
                 lowest_amplitude: float | None = None) -> JointSystem:
    """The ``nonlinear.harmonic_balance.JointSystem`` of one design of ``model`` on ``space``: the stuck modes
    (QSMA's tracked mode, refined by Rayleigh quotient iteration, and the dense solve's other modes), the
    tangential friction elements that can slip (a stuck patch group is a linear spring, part of the stuck
    structure) with their registry sliders (``FrictionModel.sliders``: Jenkins, Iwan, a core spring as one
    slider that never slips). lowest_amplitude: the lowest modal amplitude q (m kg^0.5) the system will be
    solved at; the Iwan elements' sliders then resolve the slip ratios each reaches there in the stuck mode
    (``slider_resolution``); None: the registry's default resolution, 1e-4 phi_max. Raises ValueError where the
    stuck target mode has a negative stiffness."""
    superelement = space.superelement
    elements = patch_elements(model, design, superelement.patch_groups, stuck_group)
    tangential = tangential_elements(elements)
    stuck = stuck_target_mode(space, stuck_stiffness(elements)[0])
    if not stuck.eigenvalue > 0.0:
        raise ValueError(f"the stuck target mode of this {model} design has a negative stiffness "
                         f"({stuck.eigenvalue:.6g} rad^2/s^2): the joint is too soft to carry the preload's "
                         "softening, and the structure has no vibration about its equilibrium")
    eigenvalues, shapes = stuck.eigenvalues.copy(), stuck.shapes.copy()
    eigenvalues[stuck.target], shapes[:, stuck.target] = stuck.eigenvalue, stuck.shape
    slipping = np.flatnonzero(~tangential.stuck)
    rows = tangential_rows(superelement.n_patches)[slipping]
    smallest = np.full(slipping.size, SMALLEST_SLIDER)
    if lowest_amplitude is not None:
        motion = lowest_amplitude * np.abs(space.joint_modes[tangential_rows(superelement.n_patches)]
                                           @ stuck.shape)[None, :]
        dissipation = tangential_dissipation(tangential, motion)[0, slipping]
        smallest = slider_resolution(motion[0, slipping] / slip_displacement(tangential)[0, slipping], dissipation)
    sliders = [elements.model.sliders(*(float(values[0, e]) for values in (
        tangential.slip_force, tangential.stiffness, tangential.chi, tangential.beta, tangential.theta,
        tangential.core_stiffness)), smallest=float(resolution)) for e, resolution in zip(slipping, smallest)]
    stiffness = (tangential.stiffness + tangential.core_stiffness)[0, slipping]
    return JointSystem(eigenvalues, shapes, (space.joint_modes[rows] @ shapes).T, stuck.target, stiffness,
                       stacked_sliders(sliders))


class ModeEquations(JointHarmonics):
    """The EPMC residual of one JointSystem at H harmonics and N samples (module docstring), with its analytic
    Jacobian, about the static state under ``load`` (``JointHarmonics``)."""

    def __init__(self, system: JointSystem, harmonics: int, samples: int = SAMPLES, load=None):
        super().__init__(system, harmonics, samples, load)

    def linear_mode(self, amplitude: float) -> np.ndarray:
        """Scaled unknowns of the stuck mode at modal amplitude q: U = q b cos + static motion, omega_0, xi = 0."""
        motion = np.zeros((harmonic_count(self.harmonics), self.n_t))
        motion[0], motion[1] = self.static / amplitude, self.system.target_shape
        return np.concatenate([motion.ravel(), [1.0, 0.0]])

    def __call__(self, y: np.ndarray, log_amplitude: float):
        """(R, dR/dy, dR/dlambda) at scaled unknowns y and lambda = ln q."""
        q, n_t, size = np.exp(log_amplitude), self.n_t, self.size
        mu_0, omega_0 = self.omega_0 ** 2, self.omega_0
        omega, xi = omega_0 * y[size], omega_0 * y[size + 1]
        u = y[:size]
        aft = self.deficit(q * u.reshape(-1, n_t))
        g = aft.harmonics.ravel() / q
        dg = element_jacobian(aft.jacobian)
        compliance = dynamic_compliance(self.system, omega, xi, self.harmonics)
        operator = compliance_operator(compliance.real, compliance.imaginary)
        b = self.system.target_shape
        fundamental = np.zeros(size)
        fundamental[n_t:2 * n_t] = b
        offset = np.zeros(size)
        offset[:n_t] = self.static_linear / q
        cos_rows, sin_rows = slice(n_t, 2 * n_t), slice(2 * n_t, 3 * n_t)
        residual = np.concatenate([u - operator @ g - fundamental - offset,
                                   [1.0 - y[size] ** 2 - b @ g[cos_rows] / mu_0,
                                    y[size] * y[size + 1] - b @ g[sin_rows] / mu_0]])
        jacobian = np.zeros((size + 2, size + 2))
        jacobian[:size, :size] = np.eye(size) - operator @ dg
        jacobian[:size, size] = -omega_0 * compliance_operator(compliance.real_omega, compliance.imaginary_omega) @ g
        jacobian[:size, size + 1] = -omega_0 * compliance_operator(compliance.real_xi, compliance.imaginary_xi) @ g
        jacobian[size, :size] = -b @ dg[cos_rows] / mu_0
        jacobian[size + 1, :size] = -b @ dg[sin_rows] / mu_0
        jacobian[size, size] = -2.0 * y[size]
        jacobian[size + 1, size], jacobian[size + 1, size + 1] = y[size + 1], y[size]
        along = dg @ u - g  # q d(G(q u) / q)/dq
        derivative = np.concatenate([-operator @ along + offset, [-b @ along[cos_rows] / mu_0,
                                                                  -b @ along[sin_rows] / mu_0]])
        return residual, jacobian, derivative

    def modal_harmonics(self, y: np.ndarray, log_amplitude: float) -> np.ndarray:
        """Harmonics (2H+1, n_modes) of the stuck modes' coordinates p_j (m kg^0.5) of the solution y: the
        target's fundamental q cos, every other harmonic and mode c_j^T G_k / (d_jk - i e_k) (+ load_j / mu_j)
        (``nonlinear.harmonic_balance.modal_harmonics``)."""
        q, n_t, size = np.exp(log_amplitude), self.n_t, self.size
        omega, xi = self.omega_0 * y[size], self.omega_0 * y[size + 1]
        g = self.deficit(q * y[:size].reshape(-1, n_t)).harmonics
        modal = modal_harmonics(self.system, g, omega, xi, self.load)
        if self.harmonics >= 1:
            modal[1, self.system.target], modal[2, self.system.target] = q, 0.0
        return modal


class NonlinearMode(NamedTuple):
    """The EPMC nonlinear mode at modal amplitudes q (m kg^0.5).

    frequency: omega (rad/s); damping: zeta = xi / (2 omega); joint_harmonics: (n, 2H+1, n_t) tangential joint
    motion of the slipping elements (m), (U_0, U_a1, U_b1, ...); modal_harmonics: (n, 2H+1, n_modes) the stuck
    modes' coordinates (m kg^0.5; ``JointSystem.shapes`` maps them to the joint space's coordinates), the target's
    fundamental q and the other columns the mode's shape; harmonics: H; samples: N of the AFT; converged: (n,)
    Newton converged with a periodic hysteresis; stuck_frequency: omega_0 (rad/s); continuation_points: points of
    the pseudo-arclength branch followed to reach the amplitudes.
    """

    amplitude: np.ndarray
    frequency: np.ndarray
    damping: np.ndarray
    joint_harmonics: np.ndarray
    modal_harmonics: np.ndarray
    harmonics: int
    samples: int
    converged: np.ndarray
    stuck_frequency: float
    continuation_points: int


def nonlinear_mode(system: JointSystem, amplitudes, harmonics: int, samples: int = SAMPLES, load=None,
                   step: float = 0.2) -> NonlinearMode:
    """EPMC of ``system`` at the increasing modal amplitudes (n,) m kg^0.5: Newton's method from the linear mode at
    the first amplitude, then a pseudo-arclength continuation in ln q (``nonlinear.harmonic_balance
    .pseudo_arclength``) with every further amplitude a stop of the branch, and a positive frequency asked of
    each point. Amplitudes beyond a branch that stopped (its corrector failed) are NaN and not converged."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    if amplitudes.ndim != 1 or amplitudes.size == 0 or np.any(amplitudes <= 0) or np.any(np.diff(amplitudes) <= 0):
        raise ValueError(f"amplitudes must be positive and increasing; got {amplitudes}")
    equations = ModeEquations(system, harmonics, samples, load)
    levels = np.log(amplitudes)
    start, converged_start, _ = newton(equations, equations.linear_mode(amplitudes[0]), levels[0])
    if not converged_start:
        raise RuntimeError(f"EPMC did not converge at the first amplitude {amplitudes[0]:.6g} m kg^0.5")
    branch = pseudo_arclength(equations, start, levels[0], levels[1:], step,
                              admissible=lambda y: bool(y[equations.size] > 0.0))
    solutions = [start] + [branch.unknowns[index] for index in branch.at_stops]
    solutions += [np.full(start.size, np.nan)] * (amplitudes.size - len(solutions))  # beyond where it stopped
    converged = [bool(np.all(np.isfinite(y))) and equations.deficit(
        np.exp(level) * y[:equations.size].reshape(-1, equations.n_t)).periodic
        for y, level in zip(solutions, levels)]
    solutions = np.array(solutions)
    omega = equations.omega_0 * solutions[:, equations.size]
    xi = equations.omega_0 * solutions[:, equations.size + 1]
    joint = amplitudes[:, None, None] * solutions[:, :equations.size].reshape(len(levels), -1, equations.n_t)
    modal = np.array([equations.modal_harmonics(y, level) if np.all(np.isfinite(y))
                      else np.full((harmonic_count(harmonics), system.eigenvalues.size), np.nan)
                      for y, level in zip(solutions, levels)])
    return NonlinearMode(amplitudes, omega, xi / (2.0 * omega), joint, modal, harmonics, samples,
                         np.array(converged), equations.omega_0, len(branch.parameters))


class HarmonicConvergence(NamedTuple):
    """The harmonic count chosen and the modes computed on the way: harmonics (the first count whose frequency
    and damping agree with the next count's within the tolerances at every amplitude, or the largest tried),
    converged (whether such a count was found), modes (one NonlinearMode per count tried), and the largest
    relative changes of frequency and damping between consecutive counts."""

    harmonics: int
    converged: bool
    modes: list
    frequency_change: np.ndarray
    damping_change: np.ndarray


def converged_harmonics(system: JointSystem, amplitudes, counts=HARMONICS, samples: int = SAMPLES, load=None,
                        frequency_tolerance: float = FREQUENCY_TOLERANCE,
                        damping_tolerance: float = DAMPING_TOLERANCE) -> HarmonicConvergence:
    """The number of harmonics by a convergence check: EPMC at ``amplitudes`` with each count in turn until two
    consecutive counts agree, |delta omega| / omega <= frequency_tolerance and |delta zeta| <= damping_tolerance
    zeta (plus 1e-9 absolute, for a stuck mode) at every amplitude; the smaller of the two counts is stated."""
    modes, frequency_change, damping_change = [], [], []
    for count in counts:
        if samples <= 2 * count:
            break
        modes.append(nonlinear_mode(system, amplitudes, count, samples, load))
        if len(modes) < 2:
            continue
        previous, current = modes[-2], modes[-1]
        frequency_change.append(float(np.max(np.abs(current.frequency - previous.frequency) / current.frequency)))
        damping_change.append(float(np.max(np.abs(current.damping - previous.damping)
                                           / (np.abs(current.damping) + 1e-9))))
        if frequency_change[-1] <= frequency_tolerance and damping_change[-1] <= damping_tolerance:
            return HarmonicConvergence(previous.harmonics, True, modes, np.array(frequency_change),
                                       np.array(damping_change))
    return HarmonicConvergence(modes[-1].harmonics, False, modes, np.array(frequency_change), np.array(damping_change))


def slip_amplitude(space: JointSpace, model: str, design, stuck_group: int | None = None) -> float:
    """The modal amplitude q (m kg^0.5) at which the first tangential element of the design reaches its macroslip
    displacement (F_S / K_T or phi_max) in the stuck mode, min_e phi_e / |b_e|: the scale of an amplitude range
    from stuck into macroslip. Infinite where no element can slip or none moves."""
    elements = patch_elements(model, design, space.superelement.patch_groups, stuck_group)
    slip = slip_displacement(tangential_elements(elements))[0]
    shape = stuck_target_mode(space, stuck_stiffness(elements)[0]).shape
    joint_shape = space.joint_modes[tangential_rows(space.superelement.n_patches)] @ shape
    with np.errstate(divide="ignore"):
        return float(np.min(slip / np.abs(joint_shape)))


class ModeComparison(NamedTuple):
    """EPMC and QSMA of one design at the same modal amplitudes: the nonlinear mode (at the harmonic count the
    convergence check chose), the check itself, and QSMA's result (``nonlinear.qsma.QSMAResult``)."""

    mode: NonlinearMode
    harmonics: HarmonicConvergence
    qsma: object


def compare_with_qsma(space: JointSpace, model: str, design, amplitudes, counts=HARMONICS, samples: int = SAMPLES,
                      check_levels: int = 3, stuck_group: int | None = None) -> ModeComparison:
    """EPMC of a design (its sliders resolving the lowest amplitude, ``joint_system``) with its harmonic count
    chosen by ``converged_harmonics`` at ``check_levels`` amplitudes spread over ``amplitudes`` (the first, the
    last and between), then at every amplitude; QSMA
    (``nonlinear.qsma.qsma_reference``) at the same amplitudes, without linear damping on either."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    system = joint_system(space, model, design, stuck_group, lowest_amplitude=float(amplitudes[0]))
    checked = amplitudes[np.unique(np.linspace(0, amplitudes.size - 1, check_levels).round().astype(int))]
    harmonics = converged_harmonics(system, checked, counts, samples)
    mode = nonlinear_mode(system, amplitudes, harmonics.harmonics, samples)
    return ModeComparison(mode, harmonics, qsma_reference(space, model, design, amplitudes=amplitudes,
                                                          stuck_group=stuck_group))
