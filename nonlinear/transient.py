"""Transient ring-down of the reduced jointed model with discretised hysteretic joint elements.

The independent check of QSMA (DESIGN.md section 5): the same superelement and joint, but integrated in time
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
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.condensation import JointSpace, stuck_modes, stuck_stiffness_matrix
from nonlinear.joint import patch_elements, stuck_stiffness, tangential_elements, tangential_rows
from nonlinear.sliders import Sliders, initial_state, iwan_sliders, jenkins_sliders, slider_response

NEWTON_TOLERANCE = 1e-10  # residual force relative to the largest inertia, stiffness or joint force term
MAX_NEWTON_ITERATIONS = 40


class RingDown(NamedTuple):
    """Sampled response: time (steps,) s; sensors (steps, n_sensors) m; modal_amplitude (steps,) the
    projection q = phi_0^T M u on the tracked stuck mode (m kg^0.5); joint_displacement (steps,
    3 n_patches) m; stuck_frequency omega_0 rad/s; unconverged_steps: steps whose Newton iterations
    did not reach the tolerance (0 for a trustworthy run)."""

    time: np.ndarray
    sensors: np.ndarray
    modal_amplitude: np.ndarray
    joint_displacement: np.ndarray
    stuck_frequency: float
    unconverged_steps: int


def element_sliders(model: str, design, patch_groups, stuck_group: int | None = None) -> list[Sliders]:
    """The tangential joint elements of one design as slider sets, ordered (x, y) per patch; a stuck patch
    is a single slider that never slips."""
    tangential = tangential_elements(patch_elements(model, design, patch_groups, stuck_group))
    sliders = []
    for j in range(tangential.stiffness.shape[1]):
        slip_force, stiffness = tangential.slip_force[0, j], tangential.stiffness[0, j]
        if tangential.stuck[j]:
            sliders.append(Sliders(np.array([stiffness]), np.array([np.inf])))
        elif tangential.law == "jenkins":
            sliders.append(jenkins_sliders(stiffness, slip_force))
        else:
            sliders.append(iwan_sliders(slip_force, stiffness, tangential.chi[0, j], tangential.beta[0, j],
                                        tangential.theta[0, j]))
    return sliders


def ring_down(space: JointSpace, model: str, design, duration: float, time_step: float,
              initial_modal_velocity: float = 0.0, initial_modal_amplitude: float = 0.0,
              linear_damping: float = 0.0, stuck_group: int | None = None) -> RingDown:
    """Free decay of one design from an initial state in the shape of the tracked stuck mode phi_0:
    u(0) = initial_modal_amplitude phi_0 (an initial-condition start) and/or u'(0) = initial_modal_velocity
    phi_0 (an impulse, in m kg^0.5 / s). duration, time_step: s. Returns every sample."""
    superelement = space.superelement
    elements = patch_elements(model, design, superelement.patch_groups, stuck_group)
    joint_stiffness = stuck_stiffness(elements)[0]
    modes = stuck_modes(space, joint_stiffness[None, :])
    shape = modes.shape[0]
    stuck_eigenvalues, stuck_shapes = np.linalg.eigh(stuck_stiffness_matrix(space, joint_stiffness))
    damping = (stuck_shapes * (2.0 * linear_damping * np.sqrt(np.abs(stuck_eigenvalues)))) @ stuck_shapes.T
    sliders = element_sliders(model, design, superelement.patch_groups, stuck_group)
    states = [initial_state(s) for s in sliders]
    tangential = tangential_rows(superelement.n_patches)
    normal = np.setdiff1d(np.arange(3 * superelement.n_patches), tangential)
    phi, stiffness = space.joint_modes, space.eigenvalues

    def joint_force(eta, states):
        """Joint forces (3 n_patches) N, tangent stiffnesses, and the trial slider states."""
        r = phi @ eta
        force, tangent = np.empty_like(r), np.empty_like(r)
        force[normal], tangent[normal] = joint_stiffness[normal] * r[normal], joint_stiffness[normal]
        trial_states = []
        for row, element, (position, direction) in zip(tangential, sliders, states):
            force[row], tangent[row], *state = slider_response(r[row], position, direction, element)
            trial_states.append(state)
        return force, tangent, trial_states

    n_steps = int(round(duration / time_step)) + 1
    eta, velocity = initial_modal_amplitude * shape, initial_modal_velocity * shape
    force, _, _ = joint_force(eta, states)
    acceleration = -(damping @ velocity + stiffness * eta + phi.T @ force)
    history = np.empty((n_steps, len(eta)))
    history[0] = eta
    unconverged = 0
    a0, a1 = 4.0 / time_step ** 2, 2.0 / time_step
    for step in range(1, n_steps):
        predicted = eta.copy()
        for _ in range(MAX_NEWTON_ITERATIONS):
            new_acceleration = a0 * (predicted - eta) - 2.0 * a1 * velocity - acceleration
            new_velocity = velocity + 0.5 * time_step * (acceleration + new_acceleration)
            force, tangent, trial_states = joint_force(predicted, states)
            elastic, joint = stiffness * predicted, phi.T @ force
            residual = new_acceleration + damping @ new_velocity + elastic + joint
            scale = np.max(np.abs(new_acceleration) + np.abs(elastic) + np.abs(joint)) + np.finfo(float).tiny
            if np.max(np.abs(residual)) <= NEWTON_TOLERANCE * scale:
                break
            jacobian = a0 * np.eye(len(eta)) + a1 * damping + np.diag(stiffness) + (phi.T * tangent) @ phi
            predicted = predicted - np.linalg.solve(jacobian, residual)
        else:
            unconverged += 1
        eta, velocity, acceleration, states = predicted, new_velocity, new_acceleration, trial_states
        history[step] = eta
    return RingDown(
        time=np.arange(n_steps) * time_step,
        sensors=history @ (superelement.sensors @ space.modes).T,
        modal_amplitude=history @ shape,
        joint_displacement=history @ phi.T,
        stuck_frequency=float(np.sqrt(modes.eigenvalue[0])),
        unconverged_steps=unconverged)
