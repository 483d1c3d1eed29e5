"""QSMA for many designs per call: the formulation of ``nonlinear.qsma`` vectorised over designs.

Per design only 2 n_patches tangential joint unknowns are nonlinear (DESIGN.md section 5.1); everything
linear is condensed exactly into the joint-space compliance (``nonlinear.condensation.stuck_modes``, one
batched symmetric eigen-decomposition). The levels are then solved for all designs at once by a damped
Newton method with the analytic Jacobian, in unknowns scaled by each element's macroslip displacement, with
a backtracking line search on the residual and continuation from level to level. A design-level that does
not reach the tolerance is flagged with the reason, never dropped.
"""

from __future__ import annotations

import numpy as np

from nonlinear.condensation import UNAMBIGUOUS_MAC, JointSpace, stuck_modes
from nonlinear.joint import (PatchElements, patch_elements, slip_displacement, stuck_stiffness,
                             tangential_elements, tangential_rows, tangential_slip_deficit,
                             tangential_slip_deficit_potential, tangential_slip_deficit_tangent)
from nonlinear.qsma import AMBIGUOUS_MODE, CONVERGED, MACROSLIP, NOT_CONVERGED, QSMAResult, modal_backbone

TARGET_TOLERANCE = 1e-14  # iterate until the residual, relative to the joint motion, is below this ...
ACCEPT_TOLERANCE = 1e-10  # ... or stalls; accept it below this (the oracle's criterion)
MAX_ITERATIONS = 60
MAX_HALVINGS = 40


def qsma_designs(space: JointSpace, model: str, designs, amplitudes=None, forces=None,
                 linear_damping: float = 0.0, stuck_group: int | None = None) -> QSMAResult:
    """QSMA of many designs (n_designs, n_parameters) at common increasing levels: modal amplitudes q
    (amplitude control) or modal forces alpha (force control), exactly one of them, shape (levels,).

    Returns ``QSMAResult`` with a leading design axis on every field.
    """
    if (amplitudes is None) == (forces is None):
        raise ValueError("give either amplitudes (amplitude control) or forces (force control)")
    elements = patch_elements(model, designs, space.superelement.patch_groups, stuck_group)
    tangential = tangential_elements(elements)
    modes = stuck_modes(space, stuck_stiffness(elements))
    rows = tangential_rows(space.superelement.n_patches)
    b = modes.joint_shape[:, rows]
    amplitude_control = amplitudes is not None
    compliance = (modes.residual_compliance if amplitude_control else modes.compliance)[:, rows[:, None], rows]
    levels = np.asarray(amplitudes if amplitude_control else forces, dtype=float)
    linear_per_level = b if amplitude_control else b / modes.eigenvalue[:, None]
    scale = np.where(tangential.stuck, 1.0, slip_displacement(tangential))
    # Pseudo-inverse: without the tracked mode the compliance is singular where q alone fixes the joint motion.
    compliance_inverse = np.linalg.pinv(compliance, hermitian=True)

    n_designs, n_unknowns = b.shape
    r_levels = np.full((n_designs, len(levels), n_unknowns), np.nan)
    converged = np.zeros((n_designs, len(levels)), dtype=bool)
    reason = np.full((n_designs, len(levels)), NOT_CONVERGED, dtype=object)
    x = linear_per_level * levels[0] / scale
    for level, value in enumerate(levels):
        x_level, done, unrestrained = _newton(tangential, compliance, linear_per_level * value, scale, x,
                                              compliance_inverse)
        r_levels[done, level] = x_level[done] * scale[done]
        converged[:, level] = done
        reason[done, level] = CONVERGED
        if not amplitude_control:
            reason[~done & unrestrained, level] = MACROSLIP
        x = np.where(done[:, None], x_level, x)  # continuation from the last converged level
    ambiguous = modes.mac < UNAMBIGUOUS_MAC
    converged[ambiguous], reason[ambiguous] = False, AMBIGUOUS_MODE

    per_level = PatchElements(tangential.law, *(a[:, None, :] for a in tangential[1:-1]), tangential.stuck)
    amplitude, force, frequency, damping = modal_backbone(
        per_level, r_levels, b[:, None, :], modes.eigenvalue[:, None], levels[None, :], amplitude_control,
        linear_damping)
    return QSMAResult(
        amplitude=np.broadcast_to(amplitude, converged.shape), force=np.broadcast_to(force, converged.shape),
        frequency=frequency, damping=damping, joint_displacement=r_levels,
        slip_ratio=np.where(tangential.stuck, 0.0, np.abs(r_levels) / scale[:, None, :]),
        converged=converged, reason=reason.astype(str), stuck_frequency=np.sqrt(modes.eigenvalue), mac=modes.mac)


def _take(elements: PatchElements, designs) -> PatchElements:
    """The elements of a subset of designs."""
    return PatchElements(elements.law, *(a[designs] for a in elements[1:-1]), elements.stuck)


def _residual(elements, compliance, linear, scale, x):
    """Scaled residual (r - linear - compliance g(r)) / scale at r = x scale, (n, 2 n_patches), and the
    relative error: max |r - linear - compliance g| over the largest of the three terms (its round-off
    floor is machine precision; deep macroslip of very stiff elements makes the terms much larger than r)."""
    r = x * scale
    slip_term = np.einsum("dij,dj->di", compliance, tangential_slip_deficit(elements, r))
    residual = r - linear - slip_term
    magnitude = np.max(np.maximum(np.maximum(np.abs(r), np.abs(linear)), np.abs(slip_term)), axis=-1)
    return residual / scale, np.max(np.abs(residual), axis=-1) / magnitude


def _solve(matrices, right_hand_sides):
    """Batched linear solve. Returns the solutions and a mask of singular systems (force control beyond
    the macroslip limit: the slipping joint no longer restrains the halves), whose solution is left zero."""
    singular = np.zeros(len(matrices), dtype=bool)
    try:
        return np.linalg.solve(matrices, right_hand_sides[..., None])[..., 0], singular
    except np.linalg.LinAlgError:
        steps = np.zeros_like(right_hand_sides)
        for design, (matrix, rhs) in enumerate(zip(matrices, right_hand_sides)):
            try:
                steps[design] = np.linalg.solve(matrix, rhs)
            except np.linalg.LinAlgError:
                singular[design] = True
        return steps, singular


def _energy(elements, compliance_inverse, linear, scale, x):
    """Potential energy of the condensed static problem, whose gradient in r is the residual times C^-1:
    E(r) = (r - linear)^T C^+ (r - linear) / 2 - sum_i G_i(r_i), G the slip-deficit potential (J).
    Returns E and the magnitude of its two terms (for its round-off)."""
    r = x * scale
    excess = r - linear
    quadratic = 0.5 * np.einsum("di,dij,dj->d", excess, compliance_inverse, excess)
    potential = tangential_slip_deficit_potential(elements, r).sum(axis=-1)
    return quadratic - potential, np.abs(quadratic) + np.abs(potential)


def _newton(elements, compliance, linear, scale, x_start, compliance_inverse):
    """Damped Newton for all designs at one level. Returns the final scaled unknowns, the converged mask and
    the mask of designs whose tangent problem became singular (the slipping joint no longer restrains them).

    The step is Newton's; its length is backtracked until the potential energy decreases enough (Armijo),
    which converges for the convex Jenkins and four-parameter Iwan problems even across the kinks of the
    backbones, or, once energy differences reach round-off, until the residual decreases.
    """
    x = x_start.copy()
    residual, relative_error = _residual(elements, compliance, linear, scale, x)
    converged = np.zeros(len(x), dtype=bool)
    unrestrained = np.zeros(len(x), dtype=bool)
    active = np.arange(len(x))
    identity = np.eye(x.shape[1])
    for _ in range(MAX_ITERATIONS):
        error = relative_error[active]
        converged[active] = error <= ACCEPT_TOLERANCE
        active = active[error > TARGET_TOLERANCE]
        if active.size == 0:
            break
        sub, c, s, lin = _take(elements, active), compliance[active], scale[active], linear[active]
        c_inverse = compliance_inverse[active]
        xa, ra = x[active], residual[active]
        # Clipping the slope at K_T (a backbone tangent below zero, stiction law only, taken as zero) keeps
        # the Newton matrix positive semi-definite, so its step descends the energy towards a stable state.
        slope = np.minimum(tangential_slip_deficit_tangent(sub, xa * s), sub.stiffness)
        jacobian = identity - c * (slope * s)[:, None, :] / s[:, :, None]
        step, singular = _solve(jacobian, -ra)
        unrestrained[active[singular]] = True
        energy, energy_terms = _energy(sub, c_inverse, lin, s, xa)
        descent = np.einsum("di,dij,dj->d", step * s, c_inverse, ra * s)
        norm = np.linalg.norm(ra, axis=-1)
        length = np.ones(len(active))
        pending = np.arange(len(active))
        for _ in range(MAX_HALVINGS):
            trial = xa[pending] + length[pending, None] * step[pending]
            part = _take(sub, pending)
            trial_residual, trial_error = _residual(part, c[pending], lin[pending], s[pending], trial)
            trial_energy, _ = _energy(part, c_inverse[pending], lin[pending], s[pending], trial)
            round_off = 1e-12 * energy_terms[pending]
            armijo = trial_energy <= energy[pending] + 1e-4 * length[pending] * np.minimum(descent[pending], 0.0)
            smaller = ((np.linalg.norm(trial_residual, axis=-1) < (1.0 - 1e-4 * length[pending]) * norm[pending])
                       & (trial_energy <= energy[pending] + round_off))
            better = armijo | smaller
            x[active[pending[better]]] = trial[better]
            residual[active[pending[better]]] = trial_residual[better]
            relative_error[active[pending[better]]] = trial_error[better]
            pending = pending[~better]
            length[pending] *= 0.5
            if pending.size == 0:
                break
        stalled = np.union1d(active[pending], active[singular])  # no decrease along the Newton direction
        active = np.setdiff1d(active, stalled)
    return x, converged, unrestrained
