"""Transient ring-down of the reduced jointed model with discretised hysteretic joint elements.

The independent check of QSMA (docs/design.md section 5): the same superelement and joint, but integrated in time
with the many-slider elements of ``nonlinear.sliders`` (history-dependent, Masing by construction) instead
of QSMA's backbone and closed-form dissipation.

Coordinates are the unjoined modes of ``nonlinear.condensation.joint_space`` (identity mass, diag(lambda)
stiffness, relative joint translations r = Phi eta). Equation of motion, free vibration after the start:

    eta'' + C eta' + diag(lambda) eta + Phi^T f_J(Phi eta, history) = 0,

with f_J the tangential slider forces and the normal springs K_z r_z, and C linear modal damping zeta_0 on
every stuck mode (C = V diag(2 zeta_0 omega_k) V^T, V the stuck modes). Time integration: Newmark's average
acceleration (trapezoidal) rule, implicit and unconditionally stable (the superelement's stiff, light
interface modes reach 1e6 rad/s), no numerical damping, period error (omega dt)^2 / 12; Newton iterations
with the sliders' tangent at each step, slider states committed once a step has converged.

Starts: a modal one (initial displacement or velocity in the shape of the tracked mode), an ideal impulse at a
point (initial velocities of every mode), or a hammer pulse of finite contact time at a point, integrated as
the load Psi^T e f(t) on the right-hand side. Prefer the pulse: an ideal impulse at an ASB accelerometer puts
more energy into modes above 1 kHz than into the 200 Hz mode, up to the stiff interface modes that the
trapezoidal rule leaves undamped (its spectral radius is 1 for omega dt >> 1), and their joint motion makes
the sliders chatter (hundreds of unconverged steps); a 3 ms soft-tip pulse excites them by less than 1e-2.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from experiment.ringdown import RingDown
from nonlinear.condensation import JointSpace
from nonlinear.joint import joint_row_stiffness, patch_elements, stuck_stiffness, tangential_elements, tangential_rows
from nonlinear.qsma import stuck_target_mode
from nonlinear.sliders import Sliders, initial_state, slider_response

NEWTON_TOLERANCE = 1e-10  # residual force relative to the largest inertia, stiffness or joint force term
MAX_NEWTON_ITERATIONS = 40


class TransientResponse(NamedTuple):
    """Sampled response of a simulated ring-down, samples along the last axis as in a measured one.

    sensors: the sensor displacements as a :class:`~experiment.ringdown.RingDown` (signals (n_sensors,
    n_samples) m, time (n_samples,) s), processed like a measured file by
    :func:`experiment.backbone.ringdown_backbone`. modal_amplitude: (n_samples,) the projection
    q = phi_0^T M u on the tracked stuck mode (m kg^0.5). joint_displacement: (3 n_patches, n_samples) m.
    stuck_frequency: omega_0, rad/s. unconverged_steps: steps whose Newton iterations did not reach the
    tolerance (0 for a trustworthy run).
    """

    sensors: RingDown
    modal_amplitude: np.ndarray
    joint_displacement: np.ndarray
    stuck_frequency: float
    unconverged_steps: int


def element_sliders(model: str, design, patch_groups, stuck_group: int | None = None) -> list[Sliders]:
    """The tangential joint elements of one design as slider sets, ordered (x, y) per patch; a stuck patch
    is a single slider that never slips, and so is a core spring (iwan4_core) beside an element's sliders."""
    tangential = tangential_elements(patch_elements(model, design, patch_groups, stuck_group))
    sliders = []
    for j in range(tangential.stiffness.shape[1]):
        slip_force, stiffness = tangential.slip_force[0, j], tangential.stiffness[0, j]
        if tangential.stuck[j]:
            sliders.append(Sliders(np.array([stiffness]), np.array([np.inf])))
        else:
            sliders.append(tangential.model.sliders(slip_force, stiffness, tangential.chi[0, j],
                                                    tangential.beta[0, j], tangential.theta[0, j],
                                                    tangential.core_stiffness[0, j]))
    return sliders


def stacked_sliders(sliders: list[Sliders]) -> Sliders:
    """The elements' slider sets as one (n_elements, n_most) set, so that one call of ``slider_response``
    updates the whole joint. Shorter sets are padded with sliders of zero stiffness that never slip (no force,
    no tangent); theta becomes (n_elements, 1)."""
    most = max(len(s.stiffness) for s in sliders)
    stiffness = np.zeros((len(sliders), most))
    strength = np.full((len(sliders), most), np.inf)
    for row, s in enumerate(sliders):
        stiffness[row, :len(s.stiffness)], strength[row, :len(s.strength)] = s.stiffness, s.strength
    theta = np.array([np.broadcast_to(s.theta, ()) for s in sliders], dtype=float)[:, None]
    return Sliders(stiffness, strength, theta)


class Hammer(NamedTuple):
    """A hammer hit: a half-sine force pulse of area ``impulse`` (N s) and contact time ``duration`` (s) at a
    point. influence: (n,) displacement of the struck point in the hit's direction per unit superelement
    coordinate, e.g. a row of ``superelement.sensors`` for a hit at a sensor along its measuring axis.

    The contact time sets the bandwidth: a mode of frequency omega receives the impulse times the pulse's
    spectrum pi^2 cos(omega T / 2) / (pi^2 - (omega T)^2), which is 1 at low frequency, first zero at
    omega T = 3 pi, and falls as 1 / (omega T)^2 beyond (a soft tip excites only the low modes).
    """

    influence: np.ndarray
    impulse: float
    duration: float

    def force(self, time: float) -> float:
        """Contact force (N) at ``time`` (s): (pi I / 2T) sin(pi t / T) during the contact, else 0."""
        if not 0.0 <= time <= self.duration:
            return 0.0
        return 0.5 * np.pi * self.impulse / self.duration * np.sin(np.pi * time / self.duration)


def hammer_impulse(space: JointSpace, influence, impulse: float) -> np.ndarray:
    """Modal velocities eta'(0) (n_modes,) m kg^0.5 / s just after an ideal (zero-duration) impulse (N s).

    The impulse's generalised force is influence^T I, and with the mass-normalised unjoined modes Psi
    (identity modal mass) the momentum balance over the hit gives eta'(0) = Psi^T influence I, eta(0) = 0.
    It excites every mode the point sees, up to the superelement's stiff interface modes (1e6 rad/s).
    """
    return impulse * modal_influence(space, influence)


def modal_influence(space: JointSpace, influence) -> np.ndarray:
    """Generalised force (n_modes,) kg^-0.5 on the unjoined modes per newton at the struck point: Psi^T e."""
    return space.modes.T @ np.asarray(influence, dtype=float)


def sensor_modes(space: JointSpace, model: str, design, stuck_group: int | None = None):
    """Linear (stuck-joint) modes as a low-level modal test would identify them at the sensors.

    Returns natural frequencies (n_modes,) rad/s in increasing order, mode shapes at the sensors
    (n_sensors, n_modes) in m per unit modal amplitude q (m kg^0.5), so that modal filtering with them gives
    q, and the index of the tracked mode (largest MAC against the reference).
    """
    joint_stiffness = stuck_stiffness(patch_elements(model, design, space.superelement.patch_groups, stuck_group))[0]
    stuck = stuck_target_mode(space, joint_stiffness)
    shapes = stuck.shapes.copy()
    shapes[:, stuck.target] = stuck.shape
    return np.sqrt(np.abs(stuck.eigenvalues)), space.superelement.sensors @ space.modes @ shapes, stuck.target


def ring_down(space: JointSpace, model: str, design, duration: float, time_step: float,
              initial_modal_velocity: float = 0.0, initial_modal_amplitude: float = 0.0,
              initial_velocity: np.ndarray | None = None, hammer: Hammer | None = None, linear_damping: float = 0.0,
              stuck_group: int | None = None) -> TransientResponse:
    """Free decay of one design from an initial state.

    Modal start, in the shape of the tracked stuck mode phi_0: u(0) = initial_modal_amplitude phi_0 (an
    initial-condition start) and/or u'(0) = initial_modal_velocity phi_0 (m kg^0.5 / s). Physical start:
    initial_velocity (n_modes,) m kg^0.5 / s in the unjoined modal coordinates, added to the modal start, e.g.
    ``hammer_impulse`` for an ideal impulse at one point; or a ``hammer`` pulse from t = 0, integrated as a
    load. duration, time_step: s. Returns every sample; the sensors as a ring-down of displacements.
    """
    superelement = space.superelement
    elements = patch_elements(model, design, superelement.patch_groups, stuck_group)
    joint_stiffness = joint_row_stiffness(stuck_stiffness(elements)[0], space.joint_modes.shape[0])
    stuck = stuck_target_mode(space, joint_stiffness)
    shape = stuck.shape
    damping = (stuck.shapes * (2.0 * linear_damping * np.sqrt(np.abs(stuck.eigenvalues)))) @ stuck.shapes.T
    sliders = stacked_sliders(element_sliders(model, design, superelement.patch_groups, stuck_group))
    states = initial_state(sliders)
    tangential = tangential_rows(superelement.n_patches)
    normal = np.setdiff1d(np.arange(len(joint_stiffness)), tangential)  # linear springs: normal and rotational rows
    phi, stiffness = space.joint_modes, space.eigenvalues

    def joint_force(eta, states):
        """Joint forces (one per joint row) N, tangent stiffnesses, and the trial slider states."""
        r = phi @ eta
        force, tangent = np.empty_like(r), np.empty_like(r)
        force[normal], tangent[normal] = joint_stiffness[normal] * r[normal], joint_stiffness[normal]
        with np.errstate(invalid="ignore"):  # padding sliders: 0 / 0 in a branch np.where discards
            force[tangential], tangent[tangential], *trial_states = slider_response(r[tangential], *states, sliders)
        return force, tangent, trial_states

    n_steps = int(round(duration / time_step)) + 1
    eta = initial_modal_amplitude * shape
    velocity = initial_modal_velocity * shape
    if initial_velocity is not None:
        velocity = velocity + np.asarray(initial_velocity, dtype=float)
    hammer_load = np.zeros_like(eta) if hammer is None else modal_influence(space, hammer.influence)

    def applied(time):
        """Modal load (n_modes,) of the hammer at ``time`` (s)."""
        return hammer_load * (0.0 if hammer is None else hammer.force(time))

    force, _, _ = joint_force(eta, states)
    acceleration = applied(0.0) - (damping @ velocity + stiffness * eta + phi.T @ force)
    history = np.empty((n_steps, len(eta)))
    history[0] = eta
    unconverged = 0
    a0, a1 = 4.0 / time_step ** 2, 2.0 / time_step
    for step in range(1, n_steps):
        predicted = eta + time_step * velocity + 0.5 * time_step ** 2 * acceleration  # constant acceleration
        load = applied(step * time_step)
        for _ in range(MAX_NEWTON_ITERATIONS):
            new_acceleration = a0 * (predicted - eta) - 2.0 * a1 * velocity - acceleration
            new_velocity = velocity + 0.5 * time_step * (acceleration + new_acceleration)
            force, tangent, trial_states = joint_force(predicted, states)
            elastic, joint = stiffness * predicted, phi.T @ force
            residual = new_acceleration + damping @ new_velocity + elastic + joint - load
            scale = np.max(np.abs(new_acceleration) + np.abs(elastic) + np.abs(joint) + np.abs(load)) + np.finfo(
                float).tiny
            if np.max(np.abs(residual)) <= NEWTON_TOLERANCE * scale:
                break
            jacobian = a0 * np.eye(len(eta)) + a1 * damping + np.diag(stiffness) + (phi.T * tangent) @ phi
            predicted = predicted - np.linalg.solve(jacobian, residual)
        else:
            unconverged += 1
        eta, velocity, acceleration, states = predicted, new_velocity, new_acceleration, trial_states
        history[step] = eta
    recovery = superelement.sensors @ space.modes
    return TransientResponse(
        sensors=RingDown(np.arange(n_steps) * time_step, recovery @ history.T,
                         tuple(f"sensor {k + 1}" for k in range(recovery.shape[0])), "displacement",
                         f"transient ring-down of {superelement.name} ({model})",
                         "initial state" if hammer is None else "hammer"),
        modal_amplitude=history @ shape,
        joint_displacement=phi @ history.T,
        stuck_frequency=float(np.sqrt(stuck.eigenvalue)),
        unconverged_steps=unconverged)
