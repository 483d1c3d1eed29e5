"""Quasi-Static Modal Analysis (paper sections 4.2 and 4.3.5): the single-design reference implementation.

Plain and readable, in the relative joint coordinates; ``nonlinear.qsma_vectorised`` evaluates many designs
per call and is tested against this one.

The structure: superelement (M, K) with joint elements on the relative patch translations r = B u. The
stuck joint tangents K_d give the low-amplitude mode (lambda_1 = omega_0^2, phi_0 mass-normalised, the mode
tracked by shape, see ``nonlinear.condensation``). QSMA solves the static problem (paper Eq. 10)

    K u + B^T f_J(B u) = alpha M phi_0.

Write the joint force as f_J(r) = K_d r - g(r): g is the force lost to slip, nonzero only in the tangential
elements. With the exact joint-space compliance C = B (K + B^T K_d B)^+ B^T and b = B phi_0 this is
(docs/design.md section 5.1)

    r = (alpha / lambda_1) b + C g(r),     q = phi_0^T M u = (alpha + b^T g(r)) / lambda_1,

with only the 2 n_patches tangential components of r unknown. Prescribing the modal amplitude q instead of
alpha (amplitude control) eliminates alpha:

    r_t = q b_t + (C_tt - b_t b_t^T / lambda_1) g(r_t),

which has a solution at every amplitude, while force control has none above the macroslip force (unless a core
spring K_c, iwan4_core, holds the joint: K_d = K_T + K_c, g the Iwan element's own slip deficit). Then
(paper Eqs. 23-25) omega = sqrt(alpha / q), D = sum of element Masing dissipations + 2 pi q^2 omega^2 zeta_0
and zeta = D / (2 pi q^2 omega^2).
Units: q in m kg^0.5, alpha in N kg^-0.5 (= m kg^0.5 s^-2), omega in rad/s, r in m, D in J.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.optimize

from nonlinear.condensation import UNAMBIGUOUS_MAC, JointSpace, modal_assurance, stuck_stiffness_matrix
from nonlinear.joint import (joint_row_stiffness, patch_elements, scaled_law, slip_displacement, stuck_stiffness,
                             tangential_dissipation, tangential_elements, tangential_rows, tangential_slip_deficit)
from nonlinear.qsma_kernel import NEGLIGIBLE_DROP

CONVERGED = ""
NOT_CONVERGED = "solver did not converge"
MACROSLIP = "no equilibrium: force above the macroslip limit"
AMBIGUOUS_MODE = "target mode ambiguous: MAC < 0.5 (veering modes)"
JUMPED = ("loading path jumps: an element with stiction crosses macroslip (its force drops) on the way to this "
          "level; the equilibrium past the drop depends on the jump's dynamics, not on the load alone")
PAST_JUMP = "past a jump: the loading path jumped, or was lost at a level that failed, before this level"
SUBSTEPS = 8  # geometric substeps of a level where the loading path may jump (``nonlinear.qsma_kernel``'s)


def drops_at_macroslip(s, theta):
    """Whether an element's force drops at macroslip (stiction): s > 0 and 1 - theta above
    ``qsma_kernel.NEGLIGIBLE_DROP``; s, theta the scaled law's constants (``nonlinear.joint.scaled_law``), arrays or
    scalars of any precision. ``nonlinear.qsma_kernel.solve_levels`` forms the same mask compiled."""
    return (s > 0.0) & (theta < 1.0 - NEGLIGIBLE_DROP)


def follow_load(solve, crossed, start, start_level, level, substeps: int = SUBSTEPS):
    """The loading path from the equilibrium ``start`` at ``start_level`` to ``level`` (docs/design.md section
    5.1): ``substeps`` geometric substeps, each solved from the equilibrium of the one before.

    solve(level, start) -> (solution, converged); crossed(solution, start) -> whether an element with stiction
    is on the other side of macroslip at solution than at start. Levels are modal amplitudes or forces, positive
    and increasing. Returns (solution, reason): CONVERGED where every substep converged without such a crossing,
    else JUMPED at the first substep that crossed or NOT_CONVERGED at the first that failed, with that substep's
    solution. ``nonlinear.qsma_kernel.solve_levels`` follows the same rule compiled.
    """
    solution = start
    for k in range(1, substeps + 1):
        substep = level if k == substeps else start_level * (level / start_level) ** (k / substeps)
        trial, converged = solve(substep, solution)
        if not converged:
            return trial, NOT_CONVERGED
        if crossed(trial, solution):
            return trial, JUMPED
        solution = trial
    return solution, CONVERGED


class QSMAResult(NamedTuple):
    """QSMA backbone at a list of levels (leading design axis in the vectorised version).

    amplitude: modal amplitude q (m kg^0.5); force: modal force alpha (N kg^-0.5);
    frequency: omega (rad/s); damping: zeta (fraction of critical);
    joint_displacement: (levels, 2 n_patches) tangential relative translations r_t (m), (x, y) per patch;
    slip_ratio: (levels, 2 n_patches) |r_t| / macroslip displacement (F_S/K_T or phi_max; >= 1: macroslip,
        0 for stuck patches);
    converged: (levels,) bool; reason: (levels,) '' when converged, else why not (solver failure, no
        equilibrium above the macroslip force, or an ambiguous target mode);
    stuck_frequency: omega_0 (rad/s) of the tracked mode; mac: its MAC against the reference mode.
    """

    amplitude: np.ndarray
    force: np.ndarray
    frequency: np.ndarray
    damping: np.ndarray
    joint_displacement: np.ndarray
    slip_ratio: np.ndarray
    converged: np.ndarray
    reason: np.ndarray
    stuck_frequency: np.ndarray
    mac: np.ndarray


RAYLEIGH_REFINEMENTS = 3  # steps of Rayleigh quotient iteration after the dense eigen-solve (cubic convergence)


class StuckTargetMode(NamedTuple):
    """The tracked low-amplitude mode of one design and the dense eigen-solve it was refined from.

    eigenvalue: lambda_1 = omega_0^2, rad^2/s^2; shape: (n_modes,) unit-norm mode in the unjoined modal
    coordinates (identity mass, so mass-normalised), positive projection on the reference; mac: its MAC
    against the reference; eigenvalues, shapes: (n_modes,), (n_modes, n_modes) all modes of the dense solve,
    increasing, signs as returned; target: the tracked mode's index among them.
    """

    eigenvalue: float
    shape: np.ndarray
    mac: float
    eigenvalues: np.ndarray
    shapes: np.ndarray
    target: int


def stuck_energy_quotient(space: JointSpace, joint_stiffness, shape) -> float:
    """Rayleigh quotient of the stuck structure, rad^2/s^2, for a (n_modes,) shape, as a sum of positive strain
    energies: (sum_i lambda_i x_i^2 + sum_j k_j (Phi x)_j^2) / |x|^2.

    Each term is accurate relative to itself, so the quotient is accurate relative to the target eigenvalue;
    x^T A x with the assembled A = Lambda + Phi^T K Phi (entries up to 1e16 for 1e14 N/m joints) carries an
    absolute error of eps ||A||, up to 2e-6 of lambda_1 on stiff designs.
    """
    joint = space.joint_modes @ shape
    stiffness = joint_row_stiffness(joint_stiffness, len(joint))
    return float((space.eigenvalues @ shape ** 2 + stiffness @ joint ** 2) / (shape @ shape))


def stuck_target_mode(space: JointSpace, joint_stiffness, refinements: int = RAYLEIGH_REFINEMENTS
                      ) -> StuckTargetMode:
    """Tracked stuck mode of one design: dense eigen-solve of A = Lambda + Phi^T diag(k) Phi, the target chosen
    by MAC against the reference, then refined by Rayleigh quotient iteration (shape <- (A - lambda I)^-1
    shape, lambda <- ``stuck_energy_quotient``), which converges cubically to the eigenpair.

    joint_stiffness: (3 n_patches,) stuck tangents k, N/m (``joint_row_stiffness`` puts them on every joint
    row). The dense solve's eigenvalue is off by up to
    eps ||A|| (2e-6 of lambda_1 when joints reach 1e14 N/m); the energy quotient removes that error, and its
    error is second order in the shape's.
    """
    matrix = stuck_stiffness_matrix(space, joint_stiffness)
    eigenvalues, shapes = np.linalg.eigh(matrix)
    mac = modal_assurance(shapes, space.reference)
    target = int(np.argmax(mac))
    shape = shapes[:, target]
    eigenvalue = stuck_energy_quotient(space, joint_stiffness, shape)
    for _ in range(refinements):
        try:
            shape = np.linalg.solve(matrix - eigenvalue * np.eye(len(shape)), shape)
        except np.linalg.LinAlgError:  # the shift is an eigenvalue to machine precision: converged
            break
        shape = shape / np.linalg.norm(shape)
        eigenvalue = stuck_energy_quotient(space, joint_stiffness, shape)
    return StuckTargetMode(eigenvalue, shape * np.sign(shape @ space.reference), float(mac[target]), eigenvalues,
                           shapes, target)


def modal_frequency(force, amplitude):
    """Secant natural frequency of the modal backbone, omega = sqrt(alpha / q) (rad/s), paper Eq. (23)."""
    return np.sqrt(force / amplitude)


def damping_factor(joint_dissipation, amplitude, frequency, linear_damping):
    """zeta = D / (2 pi q^2 omega^2) with D = joint dissipation + 2 pi q^2 omega^2 zeta_0, paper Eqs. (24)-(25)."""
    return joint_dissipation / (2.0 * np.pi * amplitude ** 2 * frequency ** 2) + linear_damping


def qsma_reference(space: JointSpace, model: str, design, amplitudes=None, forces=None,
                   linear_damping: float = 0.0, stuck_group: int | None = None) -> QSMAResult:
    """QSMA of one design at prescribed modal amplitudes q (amplitude control) or modal forces alpha (force
    control); give exactly one of them, increasing (each level starts from the previous solution).

    model, design: friction model and parameter vector (``nonlinear.joint``); linear_damping: zeta_0.
    Tangential unknowns are scaled by each element's macroslip displacement so that 12 decades of parameters
    look alike to the solver (MINPACK's hybrid Powell method, finite-difference Jacobian).
    """
    if (amplitudes is None) == (forces is None):
        raise ValueError("give either amplitudes (amplitude control) or forces (force control)")
    superelement = space.superelement
    elements = patch_elements(model, design, superelement.patch_groups, stuck_group)
    tangential = tangential_elements(elements)
    joint_stiffness = stuck_stiffness(elements)[0]

    stiffness_matrix = stuck_stiffness_matrix(space, joint_stiffness)
    stuck = stuck_target_mode(space, joint_stiffness)
    eigenvalue, shape, mac = stuck.eigenvalue, stuck.shape, stuck.mac
    # LU of the assembled A: C_tt within 5e-10 of its largest entry on Table 3 designs (measured against the
    # small problem's sum of positive terms); it acts only through the slip deficit g, on omega by < 1e-9.
    compliance = space.joint_modes @ np.linalg.solve(stiffness_matrix, space.joint_modes.T)
    rows = tangential_rows(superelement.n_patches)
    b = (space.joint_modes @ shape)[rows]
    compliance = compliance[np.ix_(rows, rows)]
    amplitude_control = amplitudes is not None
    if amplitude_control:
        compliance = compliance - np.outer(b, b) / eigenvalue
    levels = np.asarray(amplitudes if amplitude_control else forces, dtype=float)

    scale = np.where(tangential.stuck, 1.0, slip_displacement(tangential))[0]

    def slip_deficit(r):
        return tangential_slip_deficit(tangential, r[None, :])[0]

    law = scaled_law(tangential)
    stiction = drops_at_macroslip(law.s, law.theta)[0]

    def solve(value, start):
        """One level from ``start`` (scaled): (scaled solution, converged)."""
        linear = value * b if amplitude_control else value / eigenvalue * b

        def residual(x_scaled):
            r = x_scaled * scale
            return (r - linear - compliance @ slip_deficit(r)) / scale

        solution = scipy.optimize.root(residual, start, method="hybr", options={"xtol": 1e-14, "maxfev": 4000})
        r = solution.x * scale
        # Round-off floor of the residual: machine precision times its largest term.
        terms = np.max([np.abs(r), np.abs(linear), np.abs(compliance @ slip_deficit(r))])
        return solution.x, bool(np.all(np.isfinite(r)) and np.max(np.abs(solution.fun * scale)) <= 1e-10 * terms)

    def regime_changed(x_scaled, previous):
        return bool(np.any(stiction & ((np.abs(x_scaled) > 1.0) != (np.abs(previous) > 1.0))))

    n_levels, n_unknowns = len(levels), len(rows)
    r_levels = np.full((n_levels, n_unknowns), np.nan)
    converged = np.zeros(n_levels, dtype=bool)
    reason = np.full(n_levels, NOT_CONVERGED, dtype=object)
    x, previous_value, lost = None, None, False
    for level, value in enumerate(levels):
        if lost:
            reason[level] = PAST_JUMP
            continue
        linear = value * b if amplitude_control else value / eigenvalue * b
        # Continuation from the last level; for the convex laws (unique equilibrium) also a fresh start. The
        # stiction law (iwan5, theta < 1) can have several equilibria: it follows the loading path only, in
        # SUBSTEPS from the last level's equilibrium where the level's solution failed or has an element with
        # stiction across macroslip, and reports no level past a jump (docs/design.md section 5.1).
        starts = [linear / scale] if x is None else [x] if tangential.model.several_equilibria else [x, linear / scale]
        for start in starts:
            solution, ok = solve(value, start)
            if ok:
                break
        if stiction.any() and x is None:  # the first level: its path from the stuck state
            lost = not ok or regime_changed(solution, np.zeros_like(solution))
            reason[level] = JUMPED if ok and lost else reason[level]
            ok = not lost
        elif stiction.any() and (not ok or regime_changed(solution, x)):
            solution, reason[level] = follow_load(solve, regime_changed, x, previous_value, value)
            ok = reason[level] == CONVERGED
            lost = not ok
        r = solution * scale
        if ok:
            r_levels[level], converged[level], reason[level] = r, True, CONVERGED
            x, previous_value = solution, value
        elif not amplitude_control and not tangential.model.core and np.all(
                tangential.stuck[0] | (np.abs(r) >= scale)):  # a core holds every force
            reason[level] = MACROSLIP
    if mac < UNAMBIGUOUS_MAC:
        converged[:], reason[:] = False, AMBIGUOUS_MODE
    amplitude, force, frequency, damping = modal_backbone(tangential, r_levels, b, eigenvalue, levels,
                                                          amplitude_control, linear_damping)
    return QSMAResult(
        amplitude=amplitude, force=force, frequency=frequency, damping=damping, joint_displacement=r_levels,
        slip_ratio=np.where(tangential.stuck, 0.0, np.abs(r_levels) / scale),
        converged=converged, reason=reason.astype(str),
        stuck_frequency=np.sqrt(eigenvalue), mac=mac)


def modal_backbone(tangential, joint_displacement, joint_shape, eigenvalue, levels, amplitude_control: bool,
                   linear_damping: float):
    """Modal amplitude, force, frequency and damping from the solved tangential joint motion.

    tangential: tangential elements broadcasting against joint_displacement (..., levels, 2 n_patches);
    joint_shape: b_t (..., 1, 2 n_patches); eigenvalue: lambda_1 (..., 1); levels: the prescribed q
    (amplitude control) or alpha (force control), (..., levels). alpha = lambda_1 q - b^T g, paper Eqs. 23-25.
    """
    deficit = tangential_slip_deficit(tangential, joint_displacement)
    modal_deficit = np.sum(deficit * joint_shape, axis=-1)
    if amplitude_control:
        amplitude = levels
        force = eigenvalue * amplitude - modal_deficit
    else:
        force = levels
        amplitude = (force + modal_deficit) / eigenvalue
    frequency = modal_frequency(force, amplitude)
    joint_dissipation = tangential_dissipation(tangential, np.abs(joint_displacement)).sum(axis=-1)
    return amplitude, force, frequency, damping_factor(joint_dissipation, amplitude, frequency, linear_damping)
