"""Extended-precision reference of single QSMA levels (mpmath, 40 digits): a test helper, not in the hot path.

Independent of both float64 solvers (``nonlinear.qsma`` and the compiled kernel) in everything but the input
data: the unjoined modes of the joint space (Lambda, Phi) and the elements' scaled slip-law constants are taken
as exact. Per design:

1. the stuck matrix A = Lambda + Phi^T diag(k) Phi and its LU, assembled in extended precision;
2. the tracked mode by inverse iteration from the float64 target (``nonlinear.qsma.stuck_target_mode``), its
   eigenvalue lambda_1 the Rayleigh quotient; b = Phi psi;
3. the tangential compliance C = Phi_t A^-1 Phi_t^T and, for amplitude control, C' = C - b_t b_t^T / lambda_1;
4. per level, damped Newton on the convex potential E(r) = (r - q b)^T C'^-1 (r - q b) / 2 - sum phi_i G(x_i),
   whose gradient C'^-1 (r - q b) - g(r) vanishes exactly where r = q b + C' g(r) (docs/design.md section 5.1): each
   level starts from the previous level's solution (the first from the stuck solution q b), and a step is
   halved until E decreases; with 40 digits, E's round-off stays far below its changes even at 1e4 slip
   displacements, where float64 loses them;
   where an element with a stiction drop changed between micro- and macroslip since the previous level, the
   level is followed from the previous level's solution in substeps, up to the first that crosses (the float64
   solvers' loading-path rule, ``nonlinear.qsma.follow_load``);
5. the full equations checked on the result in the unjoined modal coordinates eta:
   Lambda eta + Phi^T f_J(Phi eta) = alpha psi with alpha = lambda_1 q - b_t^T g and
   eta = A^-1 (alpha psi + Phi_t^T g), residual relative to the largest term.

omega = sqrt(alpha / q) and zeta = sum_i 4 phi_i (x_i g_i - 2 G_i) / (2 pi q^2 omega^2) + zeta_0 (paper Eqs.
23-25) follow in the same precision.
"""

from __future__ import annotations

import copy
from typing import NamedTuple

import mpmath
import numpy as np

from nonlinear.condensation import JointSpace
from nonlinear.joint import (joint_row_stiffness, patch_elements, scaled_law, stuck_stiffness, tangential_elements,
                             tangential_rows)
from nonlinear.qsma import CONVERGED, JUMPED, drops_at_macroslip, follow_load, stuck_target_mode

DIGITS = 40
NEWTON_TOLERANCE = mpmath.mpf(10) ** -32  # |gradient step| relative to |r| at which a level is solved
MAX_NEWTON_STEPS = 400
MAX_HALVINGS = 200


class ReferenceLevel(NamedTuple):
    """One level in extended precision (returned as Python floats / float64 arrays).

    frequency: omega (rad/s); damping: zeta; force: alpha (N kg^-0.5); joint_displacement: r_t (m);
    slip_ratio: |r_t| / phi_max (0 for stuck elements); full_residual: max |Lambda eta + Phi^T f_J - alpha psi|
    over its largest term; newton_steps: steps taken at this level.
    """

    frequency: float
    damping: float
    force: float
    joint_displacement: np.ndarray
    slip_ratio: np.ndarray
    full_residual: float
    newton_steps: int


class Factorised:
    """A square mpmath matrix's LU factors, computed once: ``solve`` is ``mpmath.lu_solve`` step for step (the
    factors and both triangular solves with 10 guard bits) without factorising the matrix again for every right-hand
    side, as ``lu_solve`` does (its copy of the matrix drops mpmath's cache of the factors)."""

    def __init__(self, matrix):
        with mpmath.workprec(mpmath.mp.prec + 10):
            self.factors, self.pivots = mpmath.mp.LU_decomp(matrix.copy())

    def solve(self, right_hand_side):
        """x with A x = b for a column b (an mpmath matrix)."""
        with mpmath.workprec(mpmath.mp.prec + 10):
            forward = mpmath.mp.L_solve(self.factors, mpmath.matrix(right_hand_side), self.pivots)
            return mpmath.mp.U_solve(self.factors, forward)


def _slip_law(x, r, s, chi, theta):
    """Slip deficit g, its slope and its integral G of one element in scaled slip (``nonlinear.slip_laws``)."""
    a = abs(x)
    sign = mpmath.sign(x)
    shape = 1 / (chi + 1) - theta / (chi + 2)
    macroslip_slope = s + r / (chi + 1)
    if a < 1:
        power = r * a ** (chi + 1) if r != 0 else mpmath.mpf(0)
        return sign * power * a * shape, power * ((chi + 2) / (chi + 1) - theta), power * a * a * shape / (chi + 3)
    beyond = a - 1
    at_macroslip = r * shape + s * (1 - theta)
    return (sign * (r * shape + macroslip_slope * beyond + s * (1 - theta)), macroslip_slope,
            r * shape / (chi + 3) + at_macroslip * beyond + macroslip_slope * beyond ** 2 / 2)


class ReferenceDesign:
    """Extended-precision stuck mode and compliances of one design (steps 1-3 above)."""

    def __init__(self, space: JointSpace, model: str, design, stuck_group: int | None = None):
        mpmath.mp.dps = DIGITS
        elements = patch_elements(model, np.asarray(design, dtype=float)[None, :], space.superelement.patch_groups,
                                  stuck_group)
        tangential = tangential_elements(elements)
        law = scaled_law(tangential)
        self.phi, self.r, self.s, self.chi, self.theta = ([mpmath.mpf(float(v)) for v in np.ravel(a)] for a in law)
        self.stuck = np.asarray(tangential.stuck, dtype=bool)
        joint_stiffness = joint_row_stiffness(stuck_stiffness(elements)[0], space.joint_modes.shape[0])
        n_modes = space.eigenvalues.size
        joint_modes = mpmath.matrix(space.joint_modes.tolist())
        stiffness = [mpmath.mpf(float(k)) for k in joint_stiffness]
        self.eigenvalues = [mpmath.mpf(float(v)) for v in space.eigenvalues]
        matrix = mpmath.matrix(n_modes, n_modes)
        for i in range(n_modes):
            for j in range(i, n_modes):
                value = mpmath.fsum(joint_modes[p, i] * stiffness[p] * joint_modes[p, j] for p in range(len(stiffness)))
                matrix[i, j] = matrix[j, i] = value
            matrix[i, i] += self.eigenvalues[i]
        self.matrix, self.joint_modes, self.joint_stiffness = matrix, joint_modes, stiffness
        self.factorised = Factorised(matrix)
        self.eigenvalue, self.shape = self._target_mode(space, joint_stiffness)
        rows = [int(i) for i in tangential_rows(space.superelement.n_patches)]
        self.rows = rows
        joint_shape = joint_modes * self.shape
        self.joint_shape = mpmath.matrix([joint_shape[i] for i in rows])
        tangential_modes = mpmath.matrix([[joint_modes[i, j] for j in range(n_modes)] for i in rows])
        self.tangential_modes = tangential_modes
        solved = [self.factorised.solve(tangential_modes.T.column(k)) for k in range(len(rows))]
        compliance = mpmath.matrix([[(tangential_modes.T.column(i).T * column)[0] for column in solved]
                                    for i in range(len(rows))])
        m = len(rows)
        self.compliance = mpmath.matrix(m, m)
        for i in range(m):
            for j in range(m):
                self.compliance[i, j] = compliance[i, j] - self.joint_shape[i] * self.joint_shape[j] / self.eigenvalue
        self.compliance_inverse = mpmath.inverse(self.compliance)

    def on_condensation(self, compliance, joint_shape, eigenvalue) -> ReferenceDesign:
        """A copy that solves the condensed problem of a float64 condensation taken as exact: the stuck tangential
        compliance C (m, m) in m/N, the joint shape b (m,) and lambda_1 (rad^2/s^2), as ``nonlinear.condensation.
        stuck_modes`` gives them; to check that a float64 level is an equilibrium of its own problem. Its
        full-equation residual keeps the 40-digit stuck mode and is not meant to be read."""
        other = copy.copy(self)
        other.eigenvalue = mpmath.mpf(float(eigenvalue))
        other.joint_shape = mpmath.matrix([mpmath.mpf(float(v)) for v in joint_shape])
        m = len(joint_shape)
        other.compliance = mpmath.matrix(m, m)
        for i in range(m):
            for j in range(m):
                other.compliance[i, j] = (mpmath.mpf(float(compliance[i, j]))
                                          - other.joint_shape[i] * other.joint_shape[j] / other.eigenvalue)
        other.compliance_inverse = mpmath.inverse(other.compliance)
        return other

    def _target_mode(self, space: JointSpace, joint_stiffness):
        """Inverse iteration from the float64 tracked mode, shifted by its eigenvalue; Rayleigh quotient."""
        start = stuck_target_mode(space, joint_stiffness)
        shape = mpmath.matrix(start.shape.tolist())
        shift = mpmath.mpf(float(start.eigenvalue))
        shifted = self.matrix - shift * mpmath.eye(self.matrix.rows)
        eigenvalue = shift
        factorised = Factorised(shifted)
        for _ in range(8):
            shape = factorised.solve(shape)
            shape = shape / mpmath.norm(shape)
            updated = (shape.T * self.matrix * shape)[0]
            converged = abs(updated - eigenvalue) <= mpmath.mpf(10) ** (-DIGITS + 4) * abs(updated)
            eigenvalue = updated
            if converged:
                break
        reference = mpmath.matrix(space.reference.tolist())
        if (shape.T * reference)[0] < 0:
            shape = -shape
        return eigenvalue, shape

    def laws(self, r):
        """Deficit, slope and potential of every tangential element at joint displacements r (m): in N, N/m and
        J (the scaled law's values times 1 / phi and phi)."""
        values = [_slip_law(r[i] / self.phi[i], self.r[i], self.s[i], self.chi[i], self.theta[i])
                  for i in range(len(self.phi))]
        deficit = mpmath.matrix([v[0] for v in values])
        slope = mpmath.matrix([v[1] / self.phi[i] for i, v in enumerate(values)])
        potential = mpmath.matrix([v[2] * self.phi[i] for i, v in enumerate(values)])
        return deficit, slope, potential

    def energy(self, r, amplitude):
        excess = r - amplitude * self.joint_shape
        deficit, slope, potential = self.laws(r)
        quadratic = (excess.T * self.compliance_inverse * excess)[0] / 2
        return quadratic - mpmath.fsum(potential), excess, deficit, slope

    def solve(self, amplitude, start):
        """Damped Newton on E at modal amplitude q from ``start`` (mpmath column): (r, steps)."""
        amplitude = mpmath.mpf(float(amplitude))
        r = start
        energy, excess, deficit, slope = self.energy(r, amplitude)
        m = len(self.phi)
        for step_count in range(1, MAX_NEWTON_STEPS + 1):
            gradient = self.compliance_inverse * excess - deficit
            hessian = self.compliance_inverse - mpmath.diag([slope[i] for i in range(m)])
            # Newton's step where the Hessian is positive definite; elsewhere (the stiction law softening, a flat
            # slide) shifted by mu I, mu growing until it is (Levenberg-Marquardt: a descent direction that turns
            # towards steepest descent as mu grows, instead of crawling down a flat energy by steepest descent).
            size = max(abs(hessian[i, i]) for i in range(m))
            shift = mpmath.mpf(0)
            while True:
                try:
                    step = mpmath.cholesky_solve(hessian + shift * mpmath.eye(m), -gradient)
                    break
                except (ValueError, ZeroDivisionError):
                    shift = size * mpmath.mpf(10) ** -30 if shift == 0 else shift * 100
            descent = (gradient.T * step)[0]
            length = mpmath.mpf(1)
            for _ in range(MAX_HALVINGS):
                trial = r + length * step
                trial_energy, trial_excess, trial_deficit, trial_slope = self.energy(trial, amplitude)
                if trial_energy <= energy + mpmath.mpf(10) ** -4 * length * descent:
                    break
                length /= 2
            else:
                raise RuntimeError("extended-precision reference: no descent along the Newton step")
            r, energy, excess, deficit, slope = trial, trial_energy, trial_excess, trial_deficit, trial_slope
            if mpmath.norm(length * step) <= NEWTON_TOLERANCE * max(mpmath.norm(r), mpmath.mpf(10) ** -300):
                return r, step_count
        raise RuntimeError(f"extended-precision reference: {MAX_NEWTON_STEPS} Newton steps without convergence")

    def level(self, amplitude, r, steps: int, linear_damping: float) -> ReferenceLevel:
        """omega, zeta and the full-equation residual at a solved level."""
        amplitude = mpmath.mpf(float(amplitude))
        deficit, _, potential = self.laws(r)
        force = self.eigenvalue * amplitude - (self.joint_shape.T * deficit)[0]
        omega_squared = force / amplitude
        dissipation = mpmath.fsum(4 * (r[i] * deficit[i] - 2 * potential[i]) for i in range(len(self.phi)))
        damping = dissipation / (2 * mpmath.pi * amplitude ** 2 * omega_squared) + mpmath.mpf(linear_damping)
        return ReferenceLevel(
            frequency=float(mpmath.sqrt(omega_squared)), damping=float(damping), force=float(force),
            joint_displacement=np.array([float(v) for v in r]),
            slip_ratio=np.array([0.0 if self.stuck[i] else float(abs(r[i]) / self.phi[i]) for i in range(len(r))]),
            full_residual=float(self.full_residual(force, r, deficit)), newton_steps=steps)

    def full_residual(self, force, r, deficit):
        """max |Lambda eta + Phi^T f_J(Phi eta) - alpha psi| / largest term, with eta = A^-1 (alpha psi +
        Phi_t^T g) and f_J = K_d (Phi eta) - g on the tangential rows; also requires Phi_t eta = r."""
        load = force * self.shape + self.tangential_modes.T * deficit
        eta = self.factorised.solve(load)
        joint = self.joint_modes * eta
        joint_force = mpmath.matrix([self.joint_stiffness[p] * joint[p] for p in range(joint.rows)])
        for k, row in enumerate(self.rows):
            joint_force[row] -= deficit[k]
        n_modes = self.matrix.rows
        elastic = [self.eigenvalues[i] * eta[i] for i in range(n_modes)]
        coupling = self.joint_modes.T * joint_force
        residual = max(abs(elastic[i] + coupling[i] - force * self.shape[i]) for i in range(n_modes))
        largest = max(max(abs(elastic[i]), abs(coupling[i]), abs(force * self.shape[i])) for i in range(n_modes))
        compatibility = max(abs(joint[row] - r[k]) for k, row in enumerate(self.rows)) / max(
            abs(joint[row]) for row in self.rows)
        return max(residual / largest, compatibility)


def reference_levels(space: JointSpace, model: str, design, amplitudes, linear_damping: float = 0.0,
                     stuck_group: int | None = None) -> tuple[list[ReferenceLevel], str]:
    """QSMA of one design at increasing modal amplitudes q (m kg^0.5) in extended precision, level by level
    from the stuck solution, each level starting from the previous one, up to the first level where the loading
    path jumps. The loading path's rule of the float64 solvers (``nonlinear.qsma.follow_load``, docs/design.md
    section 5.1): where an element with a stiction drop is on the other side of macroslip than at the previous
    level, the level is followed again from the previous level's equilibrium in substeps. Returns the levels
    before the jump and ``nonlinear.qsma.CONVERGED``, or ``JUMPED`` where the path jumped."""
    reference = ReferenceDesign(space, model, design, stuck_group)
    stiction = [drops_at_macroslip(reference.s[i], reference.theta[i]) for i in range(len(reference.phi))]

    def regime(r):
        return [abs(r[i]) > reference.phi[i] for i in range(len(reference.phi))]

    def crossed(r, start):
        return any(a and b != c for a, b, c in zip(stiction, regime(r), regime(start)))

    def solve(amplitude, start):
        return reference.solve(amplitude, start)[0], True

    r = mpmath.mpf(float(amplitudes[0])) * reference.joint_shape
    levels, previous = [], None
    for amplitude in amplitudes:
        start = r
        r, steps = reference.solve(amplitude, start)
        if previous is None and crossed(r, 0 * r):  # the path from the stuck state crossed before the first level
            return levels, JUMPED
        if previous is not None and crossed(r, start):
            r, reason = follow_load(solve, crossed, start, previous, amplitude)
            if reason != CONVERGED:
                return levels, reason
            r, steps = reference.solve(amplitude, r)  # the level's own Newton steps (a polish from there)
        levels.append(reference.level(amplitude, r, steps, linear_damping))
        previous = float(amplitude)
    return levels, CONVERGED
