"""Harmonic balance of the jointed structure in its condensed joint space, with the friction forces evaluated in
time by alternating frequency/time (AFT), and a pseudo-arclength continuation.

The structure (docs/design.md section 5.1): unjoined modes eta (identity mass, stiffness diag(lambda)), joint
motions r = Phi eta, joint forces f_J(r) = K_d r - g(r) with K_d the stuck tangents and g the force lost to slip,
nonzero only in the tangential friction elements. With the stuck structure's modes A v_j = mu_j v_j
(A = diag(lambda) + Phi^T K_d Phi) and c_j = Phi_t v_j the tangential joint motion of mode j, the equation of
motion of the modal coordinate p_j = v_j^T eta is

    p_j'' - xi p_j' + mu_j p_j = c_j^T g(r_t(t)),       r_t = sum_j c_j p_j,

where -xi p' is the negative mass-proportional damping of the extended periodic motion concept (``nonlinear.epmc``;
xi = 0 for a conservative system), or, one xi_j = -2 zeta_j sqrt(mu_j) per mode, the viscous modal damping of a
forced structure (``nonlinear.forced_response``, whose harmonic force adds to harmonic 1 of the right-hand side).
A periodic motion r_t(tau), tau = omega t, is written as the real Fourier series r_t = U_0 + sum_k (U_ak cos k tau
+ U_bk sin k tau), k = 1..H; in complex form R_k = U_ak - i U_bk and d/dt -> i k omega, so that harmonic k of mode
j is

    P_jk = c_j^T G_k / (d_jk - i e_jk),   d_jk = mu_j - (k omega)^2,   e_jk = k omega xi_j,

G_k the harmonics of g. Summed over the modes, the tangential joint motion of harmonic k is the dynamic
compliance of the stuck structure applied to the slip deficit (real form):

    U_ak = Hd_k G_ak + He_k G_bk,   U_bk = Hd_k G_bk - He_k G_ak,
    Hd_k = sum_j c_j c_j^T d_jk / (d_jk^2 + e_jk^2),   He_k = sum_j c_j c_j^T e_jk / (d_jk^2 + e_jk^2),

Hd_0 the static compliance. Only the n_t tangential motions of the slipping elements are unknowns (10 on the BRB),
whatever the superelement's size: the condensed joint space.

AFT: the harmonics give the joint motion at N samples per period; each friction element, as its registry's parallel
sliders (``nonlinear.sliders``: Jenkins one slider, Iwan a few thousand, Masing's rules with stiction), is stepped
through whole periods from its static state until its state repeats after a period (the hysteresis is periodic);
the last period's slip deficit is transformed back to harmonics. Its Jacobian is analytic: a slider sliding at
sample n carries a constant force (derivative 0); one stuck since its last slip at sample m carries
k (u(n) - u(m)) + const (derivative k (E(n) - E(m)), E the Fourier basis row); one that never slipped carries k E(n)
(Krack and Gross, "Harmonic Balance for Nonlinear Vibration Problems", Springer 2019, ch. 3 on AFT for hysteretic
elements).

Units: r in m, forces in N, omega and xi in rad/s, modal coordinates in m kg^0.5.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from nonlinear.hysteresis_kernel import slider_periods
from nonlinear.sliders import Sliders, slider_response

MAX_PERIODS = 12  # periods of the time loop before a hysteresis that does not repeat is reported
PERIODIC_TOLERANCE = 1e-12  # slider positions repeat to this fraction of the largest joint motion


class JointSystem(NamedTuple):
    """The stuck linear structure seen from its friction elements, and the elements' sliders.

    eigenvalues: (n_modes,) mu_j of the stuck structure, rad^2/s^2 (identity mass).
    shapes: (n_modes, n_modes) its modes v_j as columns, in the coordinates the structure was given in (unit norm).
    joint_shapes: (n_modes, n_t) c_j: tangential motion of each friction element per unit modal coordinate, m.
    target: index of the mode followed (the nonlinear mode's linear limit).
    stiffness: (n_t,) stuck tangent K_d of each friction element, N/m (g = K_d r - f).
    sliders: the elements' sliders, stiffness and strength (n_t, n_sliders) (zero-stiffness padding), theta
        (n_t, 1).
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray
    joint_shapes: np.ndarray
    target: int
    stiffness: np.ndarray
    sliders: Sliders

    @property
    def target_shape(self) -> np.ndarray:
        """b = c_target (n_t,), m per unit modal amplitude."""
        return self.joint_shapes[self.target]


def stacked_sliders(elements: list[Sliders]) -> Sliders:
    """One Sliders of several elements, padded with zero-stiffness sliders (which never slide and carry nothing)
    to the largest count: arrays (n_elements, n_sliders), theta (n_elements, 1)."""
    count = max(element.stiffness.size for element in elements)
    stiffness, strength = np.zeros((len(elements), count)), np.zeros((len(elements), count))
    for row, element in enumerate(elements):
        stiffness[row, :element.stiffness.size] = element.stiffness
        strength[row, :element.strength.size] = element.strength
    theta = np.array([[float(element.theta)] for element in elements])
    return Sliders(stiffness, strength, theta)


def harmonic_count(harmonics: int) -> int:
    """Real Fourier coefficients of a series up to harmonic H: 2 H + 1 (U_0, then U_ak, U_bk for k = 1..H)."""
    return 2 * harmonics + 1


def fourier_basis(harmonics: int, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """E (N, 2H+1): the series at tau_n = 2 pi n / N (columns 1, cos k tau, sin k tau, k = 1..H), and its
    inverse P (2H+1, N) on the samples (P E = I for N > 2H). Raises ValueError for too few samples."""
    if samples <= 2 * harmonics:
        raise ValueError(f"{samples} samples per period cannot carry {harmonics} harmonics "
                         f"(expected > {2 * harmonics})")
    tau = 2.0 * np.pi * np.arange(samples) / samples
    k = np.arange(1, harmonics + 1)
    basis = np.ones((samples, harmonic_count(harmonics)))
    basis[:, 1::2], basis[:, 2::2] = np.cos(np.outer(tau, k)), np.sin(np.outer(tau, k))
    weights = np.full(harmonic_count(harmonics), 2.0 / samples)
    weights[0] = 1.0 / samples
    return basis, basis.T * weights[:, None]


class SliderState(NamedTuple):
    """Slider positions (m) and last sliding directions, arrays (n_t, n_sliders) (``nonlinear.sliders``)."""

    position: np.ndarray
    direction: np.ndarray


def virgin_state(sliders: Sliders) -> SliderState:
    """Every slider unslipped at zero displacement."""
    return SliderState(np.zeros_like(sliders.stiffness), np.zeros_like(sliders.stiffness))


class Hysteresis(NamedTuple):
    """The friction elements over one periodic period of the time loop.

    deficit: (n_t, N) slip deficit g = K_d r - f at the samples, N. jacobian: (n_t, N, N) dg(n)/du(m) of each
    element's sample n with respect to its own displacement at sample m, N/m. periods: periods run before the
    state repeated. periodic: whether it did within MAX_PERIODS. state: the slider state at the period's end.
    """

    deficit: np.ndarray
    jacobian: np.ndarray
    periods: int
    periodic: bool
    state: SliderState


def periodic_hysteresis(system: JointSystem, displacement: np.ndarray, state: SliderState,
                        max_periods: int = MAX_PERIODS) -> Hysteresis:
    """Step every element's sliders through the periodic displacement (n_t, N) (m), period after period from
    ``state``, until the state at a period's end equals that at its start (positions to PERIODIC_TOLERANCE of the
    largest motion, directions exactly); that period gives the deficit and its Jacobian (``hysteresis_jacobian``).
    Compiled (``nonlinear.hysteresis_kernel``); ``periodic_hysteresis_reference`` is the same in numpy."""
    sliders = system.sliders
    tolerance = PERIODIC_TOLERANCE * max(float(np.abs(displacement).max()), np.finfo(float).tiny)
    force, jacobian, periods, periodic, position, direction = slider_periods(
        np.ascontiguousarray(displacement, dtype=float), state.position, state.direction, sliders.stiffness,
        sliders.strength, np.ascontiguousarray(np.broadcast_to(sliders.theta, (len(displacement), 1))[:, 0],
                                               dtype=float), system.stiffness, max_periods, tolerance)
    deficit = system.stiffness[:, None] * displacement - force
    return Hysteresis(deficit, jacobian, periods, periodic, SliderState(position, direction))


@np.errstate(invalid="ignore")  # the padding sliders (k = 0, never sliding) give 0/0 in unused branches
def periodic_hysteresis_reference(system: JointSystem, displacement: np.ndarray, state: SliderState,
                        max_periods: int = MAX_PERIODS) -> Hysteresis:
    """Step every element's sliders through the periodic displacement (n_t, N) (m), period after period from
    ``state``, until the state at a period's end equals that at its start (positions to PERIODIC_TOLERANCE of the
    largest motion, directions exactly); that period gives the deficit and its Jacobian (``hysteresis_jacobian``).
    The readable oracle of ``periodic_hysteresis``: one ``nonlinear.sliders.slider_response`` step per sample."""
    sliders = system.sliders
    n_elements, samples = displacement.shape
    tolerance = PERIODIC_TOLERANCE * max(float(np.abs(displacement).max()), np.finfo(float).tiny)
    force = np.empty((n_elements, samples))
    sliding = np.empty((samples,) + sliders.stiffness.shape, dtype=bool)
    earlier_slip = np.full(sliders.stiffness.shape, -1)  # sample of each slider's last slip before the period
    periodic, periods = False, 0
    while periods < max_periods and not periodic:
        if periods:
            earlier_slip = np.where(sliding.any(axis=0), samples - 1 - np.argmax(sliding[::-1], axis=0),
                                    earlier_slip)
        start = state
        position, direction = state
        for n in range(samples):
            force[:, n], _, new_position, direction = slider_response(displacement[:, n], position, direction,
                                                                      sliders)
            sliding[n] = new_position != position
            position = new_position
        state, periods = SliderState(position, direction), periods + 1
        periodic = bool(np.all(np.abs(state.position - start.position) <= tolerance)
                        and np.array_equal(state.direction, start.direction))
    deficit = system.stiffness[:, None] * displacement - force
    return Hysteresis(deficit, hysteresis_jacobian(system, sliding, earlier_slip), periods, periodic, state)


def hysteresis_jacobian(system: JointSystem, sliding: np.ndarray, earlier_slip: np.ndarray) -> np.ndarray:
    """dg(n)/du(m) (n_t, N, N), N/m, of the last period of the time loop from each slider's sliding at each of its
    samples (N, n_t, n_sliders) bool and the sample of its last slip in the periods before (n_t, n_sliders), -1
    for none (module docstring): dg(n)/du(n) = K_d - (stiffness of the sliders stuck at n), and each slider stuck
    at n whose last slip was at sample m (of this period or, before its first slip in it, of the earlier ones)
    adds k_j at (n, m), its force being k_j (u(n) - u(m)) + const; one that never slid carries k_j u(n)."""
    stiffness = system.sliders.stiffness
    samples, n_elements = sliding.shape[0], sliding.shape[1]
    index = np.arange(samples)[:, None, None]
    last = np.maximum.accumulate(np.where(sliding, index, -1), axis=0)
    last = np.where(last < 0, earlier_slip, last)
    stuck = ~sliding & (stiffness > 0.0)
    memory = stuck & (last >= 0)
    weights = np.broadcast_to(stiffness, sliding.shape)[memory]
    cell = ((index * n_elements + np.arange(n_elements)[:, None]) * samples + last)[memory]
    jacobian = np.bincount(cell, weights=weights, minlength=samples * n_elements * samples)
    jacobian = jacobian.reshape(samples, n_elements, samples).transpose(1, 0, 2).astype(float)
    diagonal = system.stiffness[None, :] - np.sum(stiffness * stuck, axis=2)  # (N, n_t)
    jacobian[:, np.arange(samples), np.arange(samples)] += diagonal.T
    return jacobian


class SlipDeficit(NamedTuple):
    """AFT of the friction elements: harmonics G (2H+1, n_t) of the slip deficit (N), their Jacobian
    (n_t, 2H+1, 2H+1) dG[:, e] / dU[:, e] of each element with respect to its own motion's harmonics (N/m;
    elements are uncoupled), and whether the hysteresis was periodic within MAX_PERIODS."""

    harmonics: np.ndarray
    jacobian: np.ndarray
    periodic: bool


def slip_deficit_harmonics(system: JointSystem, motion: np.ndarray, basis: tuple[np.ndarray, np.ndarray],
                           state: SliderState) -> SlipDeficit:
    """Alternating frequency/time: the joint motion's harmonics (2H+1, n_t) (m) to samples, the hysteresis of
    every element (``periodic_hysteresis``) from ``state``, and back (module docstring)."""
    to_time, to_harmonics = basis
    hysteresis = periodic_hysteresis(system, (to_time @ motion).T, state)
    harmonics = to_harmonics @ hysteresis.deficit.T
    jacobian = to_harmonics @ hysteresis.jacobian @ to_time
    return SlipDeficit(harmonics, jacobian, hysteresis.periodic)


@np.errstate(invalid="ignore")  # as periodic_hysteresis: padding sliders
def static_equilibrium(system: JointSystem, load: np.ndarray, state: SliderState | None = None,
                       tolerance: float = 1e-12, max_iterations: int = 50) -> tuple[np.ndarray, SliderState]:
    """The static step: tangential joint motion r_s (n_t,) m and slider state under a static load (n_modes,)
    in the stuck modes' coordinates (N kg^-0.5), loaded from ``state`` (default virgin) in one monotone step:

        r_s = C (load_modal) + C g(r_s),   C = sum_j c_j c_j^T / mu_j,

    solved by Newton's method with the sliders' tangent (g' = K_d - tangent); exact in a finite number of
    iterations for the piecewise linear sliders. Raises ValueError where it does not converge."""
    state = virgin_state(system.sliders) if state is None else state
    c = system.joint_shapes
    compliance = (c.T / system.eigenvalues) @ c
    linear = c.T @ (np.asarray(load, dtype=float) / system.eigenvalues)
    r = linear.copy()
    for _ in range(max_iterations):
        force, tangent, position, direction = slider_response(r, *state, system.sliders)
        residual = r - linear - compliance @ (system.stiffness * r - force)
        scale = max(float(np.abs(r).max()), float(np.abs(linear).max()), np.finfo(float).tiny)
        if np.abs(residual).max() <= tolerance * scale:
            return r, SliderState(position, direction)
        r = r - np.linalg.solve(np.eye(r.size) - compliance * (system.stiffness - tangent), residual)
    raise ValueError(f"static equilibrium under the load did not converge in {max_iterations} Newton iterations")



class JointHarmonics:
    """What every harmonic-balance residual of one JointSystem shares (EPMC's ``nonlinear.epmc.ModeEquations``, the
    forced response's ``nonlinear.forced_response.ForcedEquations``): H harmonics sampled at N points a period, the
    static state under ``load`` (n_modes,) N kg^-0.5 (default none: the reduced models are linearised about their
    preloaded equilibrium, so the preload's static state is the origin with virgin sliders), its linear part
    (n_t,) m, the stuck target mode's omega_0 (rad/s) and the unknowns' joint layout (2H+1, n_t)."""

    def __init__(self, system: JointSystem, harmonics: int, samples: int, load=None):
        self.system, self.harmonics = system, harmonics
        self.basis = fourier_basis(harmonics, samples)
        self.load = np.zeros(system.eigenvalues.size) if load is None else np.asarray(load, dtype=float)
        self.static, self.state = static_equilibrium(system, self.load)
        self.static_linear = system.joint_shapes.T @ (self.load / system.eigenvalues)
        self.omega_0 = float(np.sqrt(system.eigenvalues[system.target]))
        self.n_t = system.joint_shapes.shape[1]
        self.size = harmonic_count(harmonics) * self.n_t

    def deficit(self, motion: np.ndarray) -> SlipDeficit:
        """AFT of the joint motion (2H+1, n_t) m from the static state (``slip_deficit_harmonics``)."""
        return slip_deficit_harmonics(self.system, motion, self.basis, self.state)


class ModalReceptance(NamedTuple):
    """1 / (d_jk - i e_jk) of every stuck mode j at every harmonic k = 0..H (module docstring), as its real part
    d / (d^2 + e^2) and imaginary part e / (d^2 + e^2), arrays (H+1, n_modes) in s^2 (per unit mass), and their
    derivatives with respect to omega and to the mode's own xi (``_omega``, ``_xi``), s^2 per rad/s."""

    real: np.ndarray
    imaginary: np.ndarray
    real_omega: np.ndarray
    imaginary_omega: np.ndarray
    real_xi: np.ndarray
    imaginary_xi: np.ndarray


def modal_receptance(system: JointSystem, omega: float, xi, harmonics: int,
                     resonant_target: bool = False) -> ModalReceptance:
    """The stuck modes' receptances at k omega, k = 0..H, with the damping xi (rad/s): one value for every mode
    (EPMC's negative mass-proportional damping) or one per mode (n_modes,) (viscous modal damping, negative:
    xi_j = -2 zeta_j sqrt(mu_j)). resonant_target False: the target mode's harmonic 1 is zero, where the
    nonlinear mode prescribes it (``nonlinear.epmc``)."""
    k = np.arange(harmonics + 1)[:, None]
    keep = np.ones((harmonics + 1, system.eigenvalues.size))
    if not resonant_target and harmonics >= 1:
        keep[1, system.target] = 0.0
    d = np.where(keep > 0, system.eigenvalues[None, :] - (k * omega) ** 2, 1.0)  # left out: any nonzero value
    xi = np.asarray(xi, dtype=float)
    e = np.broadcast_to(k * omega * xi, d.shape)
    denominator = d ** 2 + e ** 2
    # chain rule: dd/domega = -2 k^2 omega, de/domega = k xi, de/dxi = k omega
    real_d, real_e = (e ** 2 - d ** 2) / denominator ** 2, -2 * d * e / denominator ** 2
    imaginary_d, imaginary_e = -2 * d * e / denominator ** 2, (d ** 2 - e ** 2) / denominator ** 2
    weights = ModalReceptance(
        real=d / denominator, imaginary=e / denominator,
        real_omega=real_d * (-2 * k ** 2 * omega) + real_e * k * xi,
        imaginary_omega=imaginary_d * (-2 * k ** 2 * omega) + imaginary_e * k * xi,
        real_xi=real_e * k * omega, imaginary_xi=imaginary_e * k * omega)
    return ModalReceptance(*(value * keep for value in weights))


class DynamicCompliance(NamedTuple):
    """Hd, He (H+1, n_t, n_t) of the module docstring at (omega, xi), and their derivatives with respect to
    omega and xi (``_omega``, ``_xi``), m/N and m/N per rad/s."""

    real: np.ndarray
    imaginary: np.ndarray
    real_omega: np.ndarray
    imaginary_omega: np.ndarray
    real_xi: np.ndarray
    imaginary_xi: np.ndarray


def dynamic_compliance(system: JointSystem, omega: float, xi, harmonics: int,
                       resonant_target: bool = False) -> DynamicCompliance:
    """The stuck structure's dynamic compliance at every harmonic k = 0..H (module docstring), by its modes (no
    cancellation near a resonance): the modal receptances (``modal_receptance``, xi one value or one per mode)
    summed with c_j c_j^T. The ``_xi`` derivatives are with respect to adding the same amount to every mode's xi."""
    c = system.joint_shapes
    return DynamicCompliance(*(np.einsum("km,me,mf->kef", weights, c, c) for weights in
                               modal_receptance(system, omega, xi, harmonics, resonant_target)))


def modal_harmonics(system: JointSystem, deficit: np.ndarray, omega: float, xi, load: np.ndarray,
                    excitation: np.ndarray | None = None, resonant_target: bool = False) -> np.ndarray:
    """Harmonics (2H+1, n_modes) of the stuck modes' coordinates p_j (m kg^0.5) for the slip deficit's harmonics
    G (2H+1, n_t) (N) at (omega, xi): P_jk = (c_j^T G_k + f_j [k = 1]) / (d_jk - i e_jk) in the real form of
    ``compliance_operator``, P_j0 = (c_j^T G_0 + load_j) / mu_j; load (n_modes,) the static load and excitation
    (n_modes,) f_j the amplitude of a force f_j cos(omega t) on each mode, N kg^-0.5 (default none).
    resonant_target False: the target's harmonic 1 is left zero (``modal_receptance``)."""
    harmonics = (deficit.shape[0] - 1) // 2
    receptance = modal_receptance(system, omega, xi, harmonics, resonant_target)
    modal = deficit @ system.joint_shapes.T  # (2H+1, n_modes): c_j^T G
    modal[0] += load
    if excitation is not None:
        modal[1] += excitation
    cosine, sine = modal[1::2].copy(), modal[2::2].copy()
    modal[0] *= receptance.real[0]
    modal[1::2] = receptance.real[1:] * cosine + receptance.imaginary[1:] * sine
    modal[2::2] = receptance.real[1:] * sine - receptance.imaginary[1:] * cosine
    return modal


def compliance_operator(real: np.ndarray, imaginary: np.ndarray) -> np.ndarray:
    """The linear map of the harmonics G (2H+1, n_t) to U (2H+1, n_t) (module docstring) as a matrix
    ((2H+1) n_t, (2H+1) n_t), index h n_t + e: U_0 = Hd_0 G_0, U_a = Hd G_a + He G_b, U_b = Hd G_b - He G_a."""
    harmonics, n_t = real.shape[0] - 1, real.shape[1]
    size = harmonic_count(harmonics)
    operator = np.zeros((size, n_t, size, n_t))
    operator[0, :, 0, :] = real[0]
    for k in range(1, harmonics + 1):
        a, b = 2 * k - 1, 2 * k
        operator[a, :, a, :], operator[a, :, b, :] = real[k], imaginary[k]
        operator[b, :, b, :], operator[b, :, a, :] = real[k], -imaginary[k]
    return operator.reshape(size * n_t, size * n_t)


def element_jacobian(jacobian: np.ndarray) -> np.ndarray:
    """dG/dU as a matrix ((2H+1) n_t, (2H+1) n_t), index h n_t + e, from the per-element blocks
    (n_t, 2H+1, 2H+1): zero between different elements."""
    n_t, size = jacobian.shape[0], jacobian.shape[1]
    return np.einsum("ehk,ef->hekf", jacobian, np.eye(n_t)).reshape(size * n_t, size * n_t)


class Continuation(NamedTuple):
    """Points of a solution branch: parameters (n_points,), unknowns (n_points, n_unknowns), the Newton
    iterations each took, the index of the point at each stop reached (its length is the number reached), and
    whether the branch reached the last stop (else it stopped where the corrector failed)."""

    parameters: np.ndarray
    unknowns: np.ndarray
    iterations: np.ndarray
    at_stops: np.ndarray
    reached: bool


Residual = Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray, np.ndarray]]


def newton(residual: Residual, y: np.ndarray, parameter: float, tolerance: float = 1e-10, max_iterations: int = 30
           ) -> tuple[np.ndarray, int, bool]:
    """Newton's method on residual(y, parameter) -> (R, dR/dy, dR/dparameter) at a fixed parameter: (y, iterations,
    converged), converged where max |R| <= tolerance and the last step was below tolerance (scaled unknowns)."""
    for iteration in range(1, max_iterations + 1):
        value, jacobian, _ = residual(y, parameter)
        step = np.linalg.solve(jacobian, -value)
        y = y + step
        if np.abs(step).max() <= tolerance and np.abs(value).max() <= 1e3 * tolerance:
            return y, iteration, bool(np.abs(residual(y, parameter)[0]).max() <= tolerance)
    return y, max_iterations, False


def backtracked(residual: Residual, point: np.ndarray, correction: np.ndarray, merit: float, halvings: int = 4):
    """A Newton correction of (y, parameter), halved up to ``halvings`` times while the residual's norm exceeds
    ``merit`` (the friction forces are piecewise linear: a full step can jump to another set of sliding sliders
    and cycle): (new point, residual there with its derivatives, correction taken)."""
    for _ in range(halvings):
        evaluated = residual(point[:-1] + correction[:-1], point[-1] + correction[-1])
        if np.linalg.norm(evaluated[0]) <= merit:
            break
        correction = correction / 2.0
    else:
        evaluated = residual(point[:-1] + correction[:-1], point[-1] + correction[-1])
    return point + correction, evaluated, correction


def branch_tangent(jacobian: np.ndarray, derivative: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """The unit tangent t (n_unknowns + 1,) of a branch R(y, parameter) = 0 at a point with dR/dy (n, n) and
    dR/dparameter (n,): [dR/dy dR/dp] t = 0, oriented as the ``previous`` tangent, or, where None, along the
    increasing parameter."""
    last = np.append(np.zeros(derivative.size), 1.0)
    tangent = np.linalg.solve(np.vstack([np.column_stack([jacobian, derivative]),
                                         last if previous is None else previous]), last)
    tangent /= np.linalg.norm(tangent)
    return -tangent if tangent @ (last if previous is None else previous) < 0 else tangent


def pseudo_arclength(residual: Residual, y0: np.ndarray, start: float, stops, step: float,
                     admissible: Callable[[np.ndarray], bool] = lambda y: True, min_step: float = 1e-4,
                     max_step: float | None = None, tolerance: float = 1e-10, max_iterations: int = 12,
                     max_points: int = 2000, max_turn: float | None = None) -> Continuation:
    """Pseudo-arclength continuation of residual(y, parameter) = 0 from (y0, start), which must be a solution,
    through the increasing parameters ``stops`` (all above start). Predictor along the unit tangent t of the branch
    ([dR/dy dR/dp] t = 0, oriented as the previous one), corrector by Newton's method on R = 0 and
    t . ((y, p) - predicted) = 0; a predictor that would pass the next stop is shortened to reach it, and its
    corrector holds the parameter there instead, so that every stop is a point of the branch. The step (in the
    scaled unknowns and parameter) grows by 1.5 after a corrector of at most 3 iterations and halves after a
    failed one, or one whose point is not ``admissible`` or, with ``max_turn`` (rad), whose tangent turned by more
    than it from the step's (a step across a narrow resonance peak can land on the curve's far side; a turn that
    persists down to the smallest step is a corner of the branch, such as the onset of slip, and is taken); the
    branch ends where the step falls below ``min_step`` (``Continuation.reached`` False)."""
    stops = [float(stop) for stop in stops]
    max_step = 10.0 * step if max_step is None else max_step
    points, parameters, iterations, at_stops = [np.asarray(y0, dtype=float)], [float(start)], [0], []
    y, parameter, previous = points[0], float(start), None
    while len(at_stops) < len(stops) and len(points) < max_points:
        _, jacobian, derivative = residual(y, parameter)
        tangent = branch_tangent(jacobian, derivative, previous)
        stop = stops[len(at_stops)]
        while True:
            reaches = tangent[-1] > 0 and parameter + step * tangent[-1] >= stop
            length = (stop - parameter) / tangent[-1] if reaches else step
            predicted = np.append(y, parameter) + length * tangent
            constraint = np.append(np.zeros(y.size), 1.0) if reaches else tangent
            trial, converged, count = predicted.copy(), False, 0
            value, jacobian, derivative = residual(trial[:-1], trial[-1])
            for count in range(1, max_iterations + 1):
                system = np.vstack([np.column_stack([jacobian, derivative]), constraint])
                try:
                    correction = np.linalg.solve(system, -np.append(value, constraint @ (trial - predicted)))
                except np.linalg.LinAlgError:
                    break
                trial, (value, jacobian, derivative), correction = backtracked(residual, trial, correction,
                                                                                np.linalg.norm(value))
                if np.abs(correction).max() <= tolerance and np.abs(value).max() <= tolerance:
                    converged = admissible(trial[:-1]) and (max_turn is None or length / 2.0 < min_step or np.arccos(
                        min(1.0, branch_tangent(jacobian, derivative, tangent) @ tangent)) <= max_turn)
                    break
            if converged:
                break
            step = min(step, length) / 2.0
            if step < min_step:
                return Continuation(np.array(parameters), np.array(points), np.array(iterations),
                                    np.array(at_stops, dtype=int), False)
        y, parameter, previous = trial[:-1], float(trial[-1]), tangent
        points.append(y)
        parameters.append(parameter)
        iterations.append(count)
        if reaches:
            at_stops.append(len(points) - 1)
        if count <= 3:
            step = min(1.5 * step, max_step)
    return Continuation(np.array(parameters), np.array(points), np.array(iterations), np.array(at_stops, dtype=int),
                        len(at_stops) == len(stops))
