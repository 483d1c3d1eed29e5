"""QSMA for many designs per call: the formulation of ``nonlinear.qsma`` vectorised over designs.

Per design only 2 n_patches tangential joint unknowns are nonlinear (DESIGN.md section 5.1); everything
linear is condensed exactly into the joint-space compliance (``nonlinear.condensation.stuck_modes``, one
batched symmetric eigen-decomposition for all designs). The levels are then solved by the compiled damped
Newton method of ``nonlinear.qsma_kernel`` on the convex potential energy, in unknowns scaled by each
element's macroslip displacement, with continuation from level to level. A design-level that does not reach
the tolerance is flagged with the reason, never dropped.
"""

from __future__ import annotations

import numpy as np

from nonlinear import qsma_kernel
from nonlinear.condensation import UNAMBIGUOUS_MAC, JointSpace, stuck_modes
from nonlinear.joint import (PatchElements, patch_elements, scaled_law, stuck_stiffness, tangential_elements,
                             tangential_rows)
from nonlinear.qsma import AMBIGUOUS_MODE, CONVERGED, MACROSLIP, NOT_CONVERGED, QSMAResult, modal_backbone


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
    # Pseudo-inverse: without the tracked mode the compliance is singular where q alone fixes the joint motion.
    compliance_pinv = np.linalg.pinv(compliance, hermitian=True)
    levels = np.asarray(amplitudes if amplitude_control else forces, dtype=float)
    linear_per_level = b if amplitude_control else b / modes.eigenvalue[:, None]
    law = scaled_law(tangential)
    solutions, status = qsma_kernel.solve_levels(
        levels, np.ascontiguousarray(linear_per_level), np.ascontiguousarray(compliance), compliance_pinv,
        *(np.ascontiguousarray(np.broadcast_to(a, b.shape)) for a in law))

    converged = status == qsma_kernel.CONVERGED
    reason = np.where(converged, CONVERGED, NOT_CONVERGED).astype(object)
    if not amplitude_control:
        reason[status == qsma_kernel.UNRESTRAINED] = MACROSLIP
    ambiguous = modes.mac < UNAMBIGUOUS_MAC
    converged[ambiguous], reason[ambiguous] = False, AMBIGUOUS_MODE
    r_levels = solutions * law.phi_max[:, None, :]
    per_level = PatchElements(tangential.law, *(a[:, None, :] for a in tangential[1:-1]), tangential.stuck)
    amplitude, force, frequency, damping = modal_backbone(
        per_level, r_levels, b[:, None, :], modes.eigenvalue[:, None], levels[None, :], amplitude_control,
        linear_damping)
    return QSMAResult(
        amplitude=np.broadcast_to(amplitude, converged.shape), force=np.broadcast_to(force, converged.shape),
        frequency=frequency, damping=damping, joint_displacement=r_levels,
        slip_ratio=np.where(tangential.stuck, 0.0, np.abs(solutions)),
        converged=converged, reason=reason.astype(str), stuck_frequency=np.sqrt(modes.eigenvalue), mac=modes.mac)
