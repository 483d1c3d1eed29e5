"""QSMA for many designs per call: the formulation of ``nonlinear.qsma`` vectorised over designs.

Per design only 2 n_patches tangential joint unknowns are nonlinear (docs/design.md section 5.1); everything
linear is condensed exactly into the joint-space compliance, from the small exact stuck eigenproblem of
``nonlinear.stuck_modes`` (through ``nonlinear.condensation.stuck_modes``). The levels and the modal
backbone are then computed by the compiled damped Newton method of ``nonlinear.qsma_kernel`` on the convex
potential energy, in unknowns scaled by each element's macroslip displacement, with continuation from level
to level. A design-level that does not reach the tolerance is flagged with the reason, never dropped.
"""

from __future__ import annotations

import numpy as np

from nonlinear import qsma_kernel
from nonlinear.compiled_cache import announce_compiling
from nonlinear.compute_devices import kernels
from nonlinear.condensation import UNAMBIGUOUS_MAC, JointSpace, ModalSplit, StuckModeCache, joint_mechanisms
from nonlinear.joint import patch_elements, scaled_law, stuck_stiffness, tangential_elements, tangential_rows
from nonlinear.qsma import AMBIGUOUS_MODE, CONVERGED, JUMPED, MACROSLIP, NOT_CONVERGED, PAST_JUMP, QSMAResult

NO_STUCK_MODE = "no stuck mode found below the modal split's cutoff"
UNBALANCED = (f"slip forces off the load on a joint mechanism by more than {qsma_kernel.FORCE_ACCEPT:g} of the "
              "forces (deep macroslip)")
FLAT_ENERGY = ("flat energy: every element along a joint mechanism slides and the Newton step from the point is "
               f"above {qsma_kernel.STEP_ACCEPT:g} of the joint motion (no resolved equilibrium there)")
UNSTABLE = ("unstable: the stuck joint is too soft to carry the preload's geometric softening of the prestressed "
            "halves (a stuck mode of negative stiffness)")
# Reason codes 0 to 9 (converged, kernel failure, macroslip, ambiguous target, no stuck mode, unbalanced
# mechanism, flat energy, the loading path jumps, past a jump, unstable) and their texts, an object array: indexing
# it with the codes gives the reason strings without copying them.
REASONS = np.array([CONVERGED, NOT_CONVERGED, MACROSLIP, AMBIGUOUS_MODE, NO_STUCK_MODE, UNBALANCED, FLAT_ENERGY,
                    JUMPED, PAST_JUMP, UNSTABLE], dtype=object)


def kernel_array(values: np.ndarray) -> np.ndarray:
    """``values`` as the kernel's one compiled signature takes them: C-contiguous and writeable (copied only when
    not). A strided or read-only view is another numba signature, compiled again (about a minute)."""
    return np.require(values, requirements=["C", "W"])


def qsma_designs(space: JointSpace, model: str, designs, amplitudes=None, forces=None,
                 linear_damping: float = 0.0, stuck_group: int | None = None,
                 split: ModalSplit | None = None, stuck: StuckModeCache | None = None,
                 device: str = "cpu") -> QSMAResult:
    """QSMA of many designs (n_designs, n_parameters) at common increasing levels: modal amplitudes q
    (amplitude control) or modal forces alpha (force control), exactly one of them, shape (levels,).
    split: ``nonlinear.condensation.modal_split(space)``, formed here when neither it nor ``stuck`` is given
    (once per structure is enough). stuck: a ``StuckModeCache`` of ``space`` with the compliance on the
    tangential rows, shared by calls whose designs may have the same stuck joint (the models of a study's
    chunk); a fresh one where not given. ValueError where it is another structure's, or its compliance is on
    other rows, or on another device. device: where the stuck modes and the levels are solved
    (``nonlinear.compute_devices``: "cpu" or "cuda").

    Returns ``QSMAResult`` with a leading design axis on every field.
    """
    if (amplitudes is None) == (forces is None):
        raise ValueError("give either amplitudes (amplitude control) or forces (force control)")
    solve_levels = kernels(device).solve_levels
    announce_compiling()
    elements = patch_elements(model, designs, space.superelement.patch_groups, stuck_group)
    tangential = tangential_elements(elements)
    rows = tangential_rows(space.superelement.n_patches)
    if stuck is None:
        stuck = StuckModeCache(space, split, rows, device)
    elif not stuck.serves(space, rows, device):
        raise ValueError("stuck: a StuckModeCache of another structure, with the compliance on other rows than "
                         f"the tangential ones, or on another device than {device!r}")
    modes = stuck(stuck_stiffness(elements))
    b = np.ascontiguousarray(modes.joint_shape[:, rows])
    amplitude_control = amplitudes is not None
    levels = np.asarray(amplitudes if amplitude_control else forces, dtype=float)
    linear_per_level = b if amplitude_control else b / modes.eigenvalue[:, None]
    law = scaled_law(tangential)
    mechanisms = joint_mechanisms(space)
    joint_displacement, slip_ratio, status, amplitude, force, frequency, damping = solve_levels(
        *map(kernel_array, (levels, linear_per_level, modes.compliance, *(np.broadcast_to(a, b.shape) for a in law),
                            tangential.stuck, modes.eigenvalue, b)),
        amplitude_control, float(linear_damping),
        *map(kernel_array, (tangential.stiffness, tangential.core_stiffness, mechanisms.tangential,
                            modes.shape @ mechanisms.rigid.T, modes.found)))

    converged = status == qsma_kernel.CONVERGED
    code = np.where(converged, 0, 1).astype(np.int8)
    if not amplitude_control:
        code[status == qsma_kernel.UNRESTRAINED] = 2
    code[status == qsma_kernel.UNBALANCED] = 5
    code[status == qsma_kernel.FLAT] = 6
    code[status == qsma_kernel.JUMPED] = 7
    code[status == qsma_kernel.PAST_JUMP] = 8
    code[modes.mac < UNAMBIGUOUS_MAC] = 3
    code[~modes.found] = 4
    code[modes.unstable > 0] = 9
    converged &= code == 0
    reason = REASONS[code]  # references to a few strings, not (designs, levels) copies of up to 50 characters
    return QSMAResult(
        amplitude=amplitude, force=force, frequency=frequency, damping=damping,
        joint_displacement=joint_displacement, slip_ratio=slip_ratio, converged=converged, reason=reason,
        stuck_frequency=np.sqrt(np.where(modes.unstable > 0, np.nan, modes.eigenvalue)), mac=modes.mac)
