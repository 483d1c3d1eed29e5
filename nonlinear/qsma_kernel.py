"""Compiled (numba) solver of the condensed static QSMA problem and its modal backbone, design by design and
level by level.

For one design the unknowns are the 2 n_patches tangential joint translations in scaled form,
x_i = r_i / phi_max_i, and the equations (``nonlinear.qsma``) are

    R(x) = r - linear - C g(r) = 0,   g the slip deficits (``nonlinear.slip_laws``),

the stationarity condition of the potential energy E(r) = (r - linear)^T C^+ (r - linear) / 2 - sum G_i(r_i)
(C the compliance of the structure with the stuck tangents K_T + K_c, K_c a core spring that never slips),
convex for the Jenkins and four-parameter Iwan laws (docs/design.md section 5.1) and for the five-parameter one
away from macroslip. Newton's step uses the slope of g, clipped at K_T only where the true one (a stiction
backbone that softens) would make the Newton matrix indefinite, keeping it positive semi-definite so the step
descends E towards a stable state; only the elements that slip (slope > 0) enter its linear system, symmetric
and solved by an LDL^T factorisation where E is convex. Where E is convex on the step (``_convex_between``) a
full step that halves |R| is taken at once (after REVISITS of them that set no record of |R| in the level,
only those that do: no cycling across a kink of the law); otherwise its length is halved until E decreases
enough (Armijo) or, once E differences reach round-off, until |R| decreases (C^+ is formed only when E is
first needed). A trial's slip powers r |x|^(chi+1) come from the iterate's by a binomial series where |x|
changed by less than NEAR, as it does in the one Newton step most levels take (no logarithm and exponential
there). Levels are solved in order, each starting from the quadratic extrapolation of the last three
converged ones (continuation). The modal backbone (paper Eqs. 23-25) is evaluated in the same pass:

    amplitude control: alpha = lambda_1 q - b^T g;  force control: q = (alpha + b^T g) / lambda_1;
    omega = sqrt(alpha / q);  zeta = D / (2 pi q^2 omega^2) + zeta_0,  D = sum_i 4 phi_i (x_i g_i - 2 G_i),

the Masing dissipation of each element from its slip deficit and its integral (for a Masing loop of
amplitude a, D = 8 int_0^a f - 4 a f(a), and f = K_T u - g). Work arrays are allocated once per call.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from nonlinear.dense_linear_algebra import ldl_back_substitute, ldl_eliminate, solve_dense

# The helpers below are separate compiled functions, called from ``solve_levels`` (numba's default: LLVM may still
# inline the small ones). Copying them all into it in numba's IR (inline='always') made one function whose first
# compile took minutes and GBs, for rates about 3 % higher (docs/benchmarks.md, the first use of the kernels).
# numpy's error model: a division by zero gives an infinity or NaN instead of raising out of the whole batch of
# designs, and loops that divide need no test per division, so they vectorise (the levels 4 to 10 % faster; the
# results bitwise the same on the benchmarks' designs).
ERROR_MODEL = "numpy"
# Status codes per design and level; UNRESTRAINED: no solution, and every loaded slipping element is beyond
# macroslip (or the Newton matrix is singular): the halves slide freely.
# UNBALANCED: the condensed residual vanishes but the slip forces do not balance the load on a mechanism.
# FLAT: the residual vanishes on a point where every element along a joint mechanism slides beyond macroslip (the
# energy flat along it, to alpha's coupling), but the Newton step from the point does not: no equilibrium there.
# JUMPED: an element with a stiction drop crossed macroslip on the loading path to the level (its force dropped:
# the path jumps, and the equilibrium past the drop depends on the jump's dynamics, not on the load alone);
# PAST_JUMP: the loading path jumped, or was lost (a level or substep that failed), at an earlier level.
CONVERGED, NOT_CONVERGED, UNRESTRAINED, UNBALANCED, FLAT, JUMPED, PAST_JUMP = 0, 1, 2, 3, 4, 5, 6
# Geometric substeps of a level from the last converged one where the loading path may jump (stiction), each from
# the equilibrium of the one before: a level is on the loading path where every substep converges without an
# element with stiction crossing macroslip (the same rule in ``nonlinear.qsma`` and the 40-digit reference).
SUBSTEPS = 8
# A stiction drop of less than this share of the slip force (1 - theta) is below the resolution of the slip forces'
# balance (FORCE_ACCEPT): such an element crossing macroslip does not count as a jump of the loading path (the
# law is continuous to that accuracy, and the rule continuous in theta at 1, where iwan5 is iwan4).
NEGLIGIBLE_DROP = 1e-6
TARGET_TOLERANCE = 1e-12  # iterate until max|R| / (largest term of R) is below this ...
ACCEPT_TOLERANCE = 1e-10  # ... or stalls; accept below this (the oracle's criterion)
REFINED_ERROR = 1e-6  # below this the residual's error is measured against the terms C g is summed from
FORCE_TARGET = 1e-12  # ... and until the slip forces balance the load on the mechanisms to this ...
# ... accept below this, beyond the floor of ``_mechanism_imbalance``: levels the oracle and the 40-digit reference
# confirm reach 4e-7 where elements slid 1e9 slip displacements (the mechanism held only through alpha's coupling,
# or by a stiff element whose motion the condensation resolves to 1e-7); iterates run off along a slide are at 0.44.
FORCE_ACCEPT = 1e-6
# Where every element along a joint mechanism slides, a level is accepted only where the Newton step from it (true
# slopes, unshifted) is within this share of the largest joint motion: along the mechanism the energy is flat to
# 1e-18 of its scale, so a residual within the acceptance leaves the iterate anywhere on a slide that a whole
# Newton step (a quarter of the motion, in the cases met) still corrects; a resolved equilibrium's step is the
# residual's size times the condition number (below 1e-9 of the motion in every converged level measured).
STEP_ACCEPT = 1e-6
# Where an element slides this many slip displacements deep, an accepted level takes one more, unshifted, Newton
# step (kept where |R| does not grow): the residual's acceptance is relative to its largest term, the deep
# elements' motion, and leaves the motion of the joint's slides resolved only to that times their condition
# number (2.5e-6 of the motion on a BRB level with elements 2.9e5 slip displacements deep). The study's levels
# rarely come near.
POLISH_DEPTH = 1e2
MAX_ITERATIONS = 60
MAX_HALVINGS = 40
# A Newton step longer than STEP_LIMIT (1 + max|x|) in scaled slip is shortened to it and the Newton matrix is
# shifted (``_newton_step``) from then on in the level: along a mechanism whose elements all slip the matrix is
# singular and the full step runs off to |x| ~ 1e16, where E's round-off hides every change. The shift starts at
# SHIFT, grows tenfold on each step the line search shortens and shrinks tenfold on each full step.
STEP_LIMIT = 4.0
SHIFT = 1e-6
MAX_SHIFT = 1e3  # a step the line search cannot shorten into a descent is shifted, 100 times more each time, to this
CONTRACTION = 0.5  # a full Newton step that shrinks |R| this much is taken without the energy (E convex) ...
REVISITS = 5  # ... but after this many such steps to no record |R| in a level only those to a record
PSEUDO_INVERSE_RCOND = 1e-15  # eigenvalues of C below this times the largest count as zero (numpy's pinv)
FACTORED_CONDITION = 1e12  # below this condition number C^+ = C^-1 (no eigenvalue near the cutoff)
# Relative accuracy of the condensed compliance C and joint shape b (``nonlinear.stuck_modes``: C within 5e-10 of
# its largest entry on CD1, b within 7e-8 of max|b| on the BRB, both against 40-digit references): the holding
# elements' motion is known to no better, relative to the largest motion.
CONDENSATION_ACCURACY = 1e-7
# An element takes part in a mechanism where |d_ji| is at least this share of the mechanism's largest entry; below
# it is the round-off of the rigid modes (1e-7), e.g. the x and y slides mixing in a basis the SVD may turn.
PARTICIPATION = 1e-5
EPSILON = float(np.finfo(np.float64).eps)
NEAR = 1e-4  # a slip power within this relative change of |x| comes from the iterate's by a series (``_slip_power``)
# Rows of the work array: iterate and trial, and at each the law's deficit, clipped slope and potential, the
# scaled residual and the slip power r min(|x|, 1)^(chi+1); then the Newton step in x, the slopes in the Newton
# matrix, the level's linear joint motion, the slipping elements' Newton solution w_A and the element forces.
X, TRIAL, DEFICIT, SLOPE, POTENTIAL, TRIAL_DEFICIT, TRIAL_SLOPE, TRIAL_POTENTIAL = range(8)
RESIDUAL, TRIAL_RESIDUAL, STEP, NEWTON_SLOPE, LINEAR, RIGHT, POWER, TRIAL_POWER, FORCE = range(8, 17)
N_WORK_ROWS = 17


@numba.njit(cache=True, error_model=ERROR_MODEL)
def law_constants(r, s, chi, theta):
    """The constants of one element's scaled slip law that do not depend on the slip, formed once per design
    (N_LAW of them, N or N per unit scaled slip, exponents and shape factors dimensionless): the exponent
    chi + 1, r, the backbone's shape factor 1 / (chi + 1) - theta / (chi + 2), the macroslip slope
    s + r / (chi + 1), the microslip slope factor (chi + 2) / (chi + 1) - theta, the potential factor
    shape / (chi + 3), the stiction drop s (1 - theta) and the potential's slope beyond macroslip."""
    shape = 1.0 / (chi + 1.0) - theta / (chi + 2.0)
    stiction = s * (1.0 - theta)
    return (chi + 1.0, r, shape, s + r / (chi + 1.0), (chi + 2.0) / (chi + 1.0) - theta, shape / (chi + 3.0),
            stiction, r * shape + stiction)


N_LAW = 8
# Columns of the macroslip slope and of the stiction drop in a table of ``law_constants``.
MACROSLIP_SLOPE, STICTION = 3, 6


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _power(base, exponent):
    """base^exponent for base >= 0, exponent > 0 as 2^(exponent log2 base): a third faster than libm's pow,
    with a relative error of about (2 + |exponent log2 base|) units in the last place (1e-13 at base 1e-300,
    far below the solver's tolerance)."""
    return np.exp2(exponent * np.log2(base))


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _slip_power(x, exponent, r, base=None, base_power=None):
    """The slip power r min(|x|, 1)^(chi+1) of one element (N per unit scaled slip; exponent = chi + 1). Given
    its value base_power at a nearby base (a Newton trial from the iterate, |x| within NEAR of |base|, both in
    microslip) it comes from the binomial series of (1 + delta)^exponent, delta = |x| / |base| - 1, to the
    third power: the first omitted term is below exponent (1 - exponent) (2 - exponent) (3 - exponent) / 24
    NEAR^4 < 1e-17 of it, and four multiply-adds replace the logarithm and exponential."""
    a = abs(x)
    if base is not None and r != 0.0 and a < 1.0 and 0.0 < abs(base) < 1.0:
        delta = (a - abs(base)) / abs(base)
        if abs(delta) <= NEAR:
            return base_power * (1.0 + exponent * delta * (1.0 + (exponent - 1.0) * delta / 2.0
                                                           * (1.0 + (exponent - 2.0) * delta / 3.0)))
    return r if a >= 1.0 else r * _power(a, exponent) if r != 0.0 else 0.0


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _scaled_slip_law(x, power, shape, macroslip_slope, slope_factor, potential_factor, stiction, beyond_potential):
    """``slip_law`` from the slip power (``_slip_power``) and the constants of ``law_constants``."""
    a = abs(x)
    xm = min(a, 1.0)
    beyond = max(a - 1.0, 0.0)
    sign = 1.0 if x > 0.0 else -1.0 if x < 0.0 else 0.0
    deficit = sign * (power * xm * shape + macroslip_slope * beyond + (stiction if a > 1.0 else 0.0))
    slope = power * slope_factor if a < 1.0 else macroslip_slope
    potential = power * xm * xm * potential_factor + beyond_potential * beyond + macroslip_slope * beyond * beyond / 2.0
    return deficit, min(slope, macroslip_slope), potential


@numba.njit(cache=True, error_model=ERROR_MODEL)
def slip_law(x, r, s, chi, theta):
    """Slip deficit g (N), its slope clipped at K_T phi_max = s + r / (chi + 1) (N per unit scaled slip)
    and its integral G (N per unit scaled slip) at scaled slip x: ``nonlinear.slip_laws``' three functions
    evaluated together with a single power |x|^(chi+1) (none for Jenkins, r = 0, or beyond macroslip)."""
    exponent, r, shape, macroslip_slope, slope_factor, potential_factor, stiction, beyond = law_constants(r, s, chi,
                                                                                                          theta)
    return _scaled_slip_law(x, _slip_power(x, exponent, r), shape, macroslip_slope, slope_factor, potential_factor,
                            stiction, beyond)


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _law_table(r, s, chi, theta, table):
    """``law_constants`` of every element into table (m, N_LAW)."""
    for i in range(r.size):
        constants = law_constants(r[i], s[i], chi[i], theta[i])
        for k in range(N_LAW):
            table[i, k] = constants[k]


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _evaluate(x, table, deficit, slope, potential, power, base=None, base_power=None):
    """The slip law at every element of x (constants in ``table``, see ``_law_table``) into the four arrays;
    where a nearby base and its slip powers are given, powers from them (``_slip_power``)."""
    for i in range(x.size):
        if base is None:
            power[i] = _slip_power(x[i], table[i, 0], table[i, 1])
        else:
            power[i] = _slip_power(x[i], table[i, 0], table[i, 1], base[i], base_power[i])
        deficit[i], slope[i], potential[i] = _scaled_slip_law(x[i], power[i], table[i, 2], table[i, 3], table[i, 4],
                                                              table[i, 5], table[i, 6], table[i, 7])


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _residual(x, linear, compliance, phi, deficit, out):
    """Scaled residual R / phi into ``out``; returns (max|R| over the largest term, |R / phi|). The terms are
    |r_i|, |linear_i| and sum_j |C_ij g_j|, the magnitude C g is summed from (its round-off; in deep macroslip g
    ~ K_T r is large and C g a small difference of its terms), the last formed only where the error is between
    the target and REFINED_ERROR (elsewhere it decides nothing)."""
    m = x.size
    largest_residual, largest_term, norm = 0.0, 1e-300, 0.0
    for i in range(m):
        slip_term = 0.0
        for j in range(m):
            slip_term += compliance[i, j] * deficit[j]
        residual = x[i] * phi[i] - linear[i] - slip_term
        out[i] = residual / phi[i]
        norm += out[i] * out[i]
        largest_residual = max(largest_residual, abs(residual))
        largest_term = max(largest_term, abs(x[i] * phi[i]), abs(linear[i]), abs(slip_term))
    if TARGET_TOLERANCE < largest_residual / largest_term < REFINED_ERROR:  # the terms of C g, where they matter
        for i in range(m):
            slip_terms = 0.0
            for j in range(m):
                slip_terms += abs(compliance[i, j] * deficit[j])
            largest_term = max(largest_term, slip_terms)
    return largest_residual / largest_term, math.sqrt(norm)


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _energy(x, linear, compliance_pinv, phi, potential):
    """Potential energy E (J) and the magnitude of its terms (for its round-off)."""
    m = x.size
    quadratic, slip = 0.0, 0.0
    for i in range(m):
        excess_i = x[i] * phi[i] - linear[i]
        for j in range(m):
            quadratic += 0.5 * excess_i * compliance_pinv[i, j] * (x[j] * phi[j] - linear[j])
        slip += phi[i] * potential[i]
    return quadratic - slip, abs(quadratic) + abs(slip)


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _directional_derivative(step, compliance_pinv, residual, phi):
    """dE/dt along the scaled step: (phi dx)^T C^+ (phi R / phi), J per unit step (the gradient of E is C^+ R)."""
    derivative = 0.0
    for i in range(step.size):
        for j in range(step.size):
            derivative += step[i] * phi[i] * compliance_pinv[i, j] * residual[j] * phi[j]
    return derivative


@numba.njit(cache=True, error_model=ERROR_MODEL)
def pseudo_inverse(matrix, inverse, factor):
    """Moore-Penrose inverse of a symmetric positive semi-definite matrix into ``inverse`` (same shape;
    eigenvalues below PSEUDO_INVERSE_RCOND times the largest are dropped). Where the matrix is safely regular
    (1-norm condition number, an upper bound of the spectral one, below FACTORED_CONDITION) no eigenvalue is
    dropped and the inverse comes from its LDL^T factor, the identity carried along (``factor``, (n, 2 n), is
    work space); otherwise from its eigen-decomposition (``eigen_decomposition``, into ``factor`` then)."""
    n = matrix.shape[0]
    for i in range(n):
        for j in range(n):
            factor[i, j] = matrix[i, j]
            factor[i, n + j] = 1.0 if i == j else 0.0
    if ldl_eliminate(factor, n, 2 * n):
        for k in range(n):  # column k of the (symmetric) inverse
            ldl_back_substitute(factor, n, n + k, inverse[k])
        if _norm_1(matrix) * _norm_1(inverse) < FACTORED_CONDITION:
            return
    values, vectors = factor[0, n:], factor[:, :n]
    eigen_decomposition(matrix, values, vectors, inverse)
    largest = 0.0
    for k in range(n):
        largest = max(largest, abs(values[k]))
    cutoff = PSEUDO_INVERSE_RCOND * largest
    inverse[:] = 0.0
    for k in range(values.size):
        if values[k] > cutoff:
            for i in range(values.size):
                for j in range(values.size):
                    inverse[i, j] += vectors[i, k] * vectors[j, k] / values[k]


@numba.njit(cache=True, error_model=ERROR_MODEL)
def eigen_decomposition(matrix, values, vectors, scratch):
    """Eigenvalues (ascending, into values (n,)) and orthonormal eigenvectors (columns, into vectors (n, n)) of the
    symmetric matrix (n, n), by LAPACK (numpy's eigh). scratch (n, n) is work space of the CUDA target's version
    (``nonlinear.qsma_cuda``: Jacobi rotations, no LAPACK there), unused here."""
    eigenvalues, eigenvectors = np.linalg.eigh(matrix)
    for i in range(values.size):
        values[i] = eigenvalues[i]
        for j in range(values.size):
            vectors[i, j] = eigenvectors[i, j]


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _norm_1(matrix):
    """Largest absolute column sum."""
    largest = 0.0
    for j in range(matrix.shape[1]):
        total = 0.0
        for i in range(matrix.shape[0]):
            total += abs(matrix[i, j])
        largest = max(largest, total)
    return largest


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _slipping_matrix(compliance, phi, slopes, active, n_active, matrix, shift):
    """The upper triangle of diag((1 + shift) phi_A / slopes) - C_AA into ``matrix`` (returned) for the n_active
    slipping elements ``active[:n_active]`` (slopes in their order); read along contiguous rows of C where every
    element slips (the common case for the Iwan laws)."""
    if n_active == compliance.shape[0]:
        for a in range(n_active):
            for b in range(a + 1, n_active):
                matrix[a, b] = -compliance[a, b]
    else:
        for a in range(n_active):
            i = active[a]
            for b in range(a + 1, n_active):
                matrix[a, b] = -compliance[i, active[b]]
    for a in range(n_active):
        i = active[a]
        matrix[a, a] = (1.0 + shift) * phi[i] / slopes[a] - compliance[i, i]
    return matrix


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _factor_with_right_side(compliance, phi, slopes, residual, active, n_active, matrix, shift):
    """``_slipping_matrix`` with -R_A in column n_active, eliminated by ``ldl_eliminate``; False if the matrix
    is not positive definite."""
    for a in range(n_active):
        matrix[a, n_active] = -residual[active[a]] * phi[active[a]]
    return ldl_eliminate(_slipping_matrix(compliance, phi, slopes, active, n_active, matrix, shift), n_active,
                         n_active + 1)


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _newton_step(residual, compliance, phi, slope, step, newton_slope, matrix, right, active, x, power, table,
                 shift):
    """Newton step of R(u) = u - linear - C g(u) in u = phi x, shifted by ``shift`` (a Levenberg-Marquardt
    step, the Jacobian I - C g' replaced by (1 + shift) I - C g'), through the slipping elements A only
    (g'_i = slope_i / phi_i > 0): with w = g' du (zero off A), (1 + shift) du = C w - R and

        (diag((1 + shift) / g'_A) - C_AA) w_A = -R_A,

    a symmetric matrix, positive definite wherever the energy is convex (C^-1 >= g' is equivalent to
    1 / g' >= C) and the shift positive (then also along a mechanism on which every element slips, where the
    unshifted matrix is singular; as the shift grows the step turns towards -R / (1 + shift) = -C grad E / (1 +
    shift), a descent direction), solved by LDL^T with the right-hand side carried along as the matrix's last column. The same
    equations give du_A = w_A / g'_A directly; only the elements that stick need C w (none for the Iwan laws,
    whose elements all slip). Where a softening element's slope was clipped at K_T (five-parameter Iwan,
    theta < 1, near macroslip) the true slope is tried first: where the matrix stays positive definite with it
    the energy is locally convex, the step is Newton's own (a descent direction, and quadratic convergence
    instead of a linear one at the rate of the clipping). Where it is not (the stiction law softening, or a
    singular joint), the unsymmetric form ((1 + shift) I - C diag(g')) du = -R with the clipped slope is solved with
    pivoting instead. residual: R / phi; step: dx (out); newton_slope (m,: the slopes in the matrix, in the
    order of A), matrix (m, m + 1 or wider), right (m,) and active (m,) are work space; x, power and table
    (``_law_table``): the iterate, its slip powers and the laws. Returns True if singular."""
    m = residual.size
    n_active = np.int64(0)  # typed int64 from the start: a literal 0 reaching the calls would compile them once more
    clipped = False
    for j in range(m):
        if slope[j] > 0.0:
            active[n_active] = j
            n_active += 1
            clipped = clipped or (slope[j] == table[j, MACROSLIP_SLOPE] and abs(x[j]) < 1.0)
    factored = False
    if clipped:  # the true slopes first
        for a in range(n_active):
            i = active[a]
            newton_slope[a] = slope[i]
            if slope[i] == table[i, MACROSLIP_SLOPE] and abs(x[i]) < 1.0:  # r |x|^(chi+1) (slope factor)
                newton_slope[a] = power[i] * table[i, 4]
        factored = _factor_with_right_side(compliance, phi, newton_slope, residual, active, n_active, matrix, shift)
    if not factored:
        for a in range(n_active):
            newton_slope[a] = slope[active[a]]
        factored = _factor_with_right_side(compliance, phi, newton_slope, residual, active, n_active, matrix, shift)
    if factored:
        ldl_back_substitute(matrix, n_active, n_active, right)  # w_A
        for a in range(n_active):  # dx_A = w_A / (phi_A g'_A)
            step[active[a]] = right[a] / newton_slope[a]
    else:
        for a in range(n_active):
            i = active[a]
            right[a] = -residual[i]
            for b in range(n_active):
                j = active[b]
                matrix[a, b] = (1.0 + shift if i == j else 0.0) - compliance[i, j] * slope[j] / phi[i]
        if solve_dense(matrix, right, n_active):
            return True
        for a in range(n_active):  # dx_A, and from it w_A
            step[active[a]] = right[a]
            right[a] *= slope[active[a]]
    if n_active < m:  # the sticking elements: du = (C w - R) / (1 + shift)
        for i in range(m):
            if slope[i] > 0.0:
                continue
            coupling = 0.0
            for a in range(n_active):
                coupling += compliance[i, active[a]] * right[a]
            step[i] = (coupling / phi[i] - residual[i]) / (1.0 + shift)
    return False


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _convex_between(x, trial, slope, trial_slope, table):
    """Whether E is convex on the segment from x to trial: it is wherever each element's tangent stiffness
    K_T - g' stays >= 0 (C^+ - diag(g') >= 0, C^+ holding the stuck tangents K_T + K_c) and its deficit is
    continuous.
    Only an element with a stiction drop (five-parameter Iwan, theta < 1) can break either: its deficit jumps
    at |x| = 1 and its microslip slope, increasing with |x|, may exceed K_T near it (then clipped). Along the
    segment |x| is at most its larger end value, so both hold on it if, at both ends, |x| < 1 and the slope is
    below the macroslip slope (not clipped); and beyond macroslip (tangent 0, deficit continuous) if both ends
    are beyond it on the same side."""
    for i in range(x.size):
        if table[i, STICTION] == 0.0:
            continue
        microslip = (abs(x[i]) < 1.0 and abs(trial[i]) < 1.0 and slope[i] < table[i, MACROSLIP_SLOPE]
                     and trial_slope[i] < table[i, MACROSLIP_SLOPE])
        macroslip = (x[i] > 1.0 and trial[i] > 1.0) or (x[i] < -1.0 and trial[i] < -1.0)
        if not (microslip or macroslip):
            return False
    return True


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _mechanism_imbalance(x, phi, residual, deficit, power, stiffness, core, table, mechanisms, mechanism_load,
                         modal_force, modal_force_terms, force):
    """How far the element forces are from balancing the load on the joint's mechanisms: the full equations
    (paper Eq. 10) projected on each relative rigid motion d_j that moves the joint only tangentially
    (``nonlinear.condensation.joint_mechanisms``) read d_j^T f = alpha rigid_j^T psi, in newtons, with no term
    that grows with the motion along d_j. Returns max_j (|d_j^T f - alpha rigid_j^T psi| - floor_j) over
    sum_i |f_i| + alpha sum_j |rigid_j^T psi| (a scale of the forces, not of the displacements: an iterate that
    ran off along a mechanism, where the condensed residual is lost under the round-off of |r|, is off by a whole
    slip force here).

    The element force f = (K_T + K_c) phi x - g (N) is formed without cancellation beyond macroslip, where it is
    K_c phi x plus the constant K_T phi - r shape - stiction drop. Below macroslip it is K_T r (plus K_c r), and r
    is known only as well as the condensed equations hold and are known, |R_i| + CONDENSATION_ACCURACY max|r|: the
    floor_j = sum_i |d_ji| K_T,i (|R_i| + CONDENSATION_ACCURACY max|r|) over these holding elements (those taking
    part in d_j, PARTICIPATION, and within that uncertainty of macroslip: a Jenkins element at its kink holds any
    force up to F_S), with K_c,i in place of K_T,i beyond macroslip and added to it below where a core holds, is
    what the condensed problem resolves (a stiff holding element next to elements that slid 1e5 slip
    displacements, its own equation a difference of terms 1e5 times its motion); it is zero along a
    mechanism on which every element slides, the run-off iterate's case, and where a stuck element holds the
    largest motion itself it is CONDENSATION_ACCURACY of that element's force. The load alpha rigid_j^T psi carries the round-off of alpha = lambda_1 q - b^T g,
    8 eps (lambda_1 q + sum |b_i g_i|) (modal_force_terms), large where g ~ K_T r of elements 1e9 slip
    displacements deep: the floor holds that too. stiffness: K_T phi (N per unit scaled slip; K_T for stuck
    elements, whose law constants vanish); core: K_c phi (N per unit scaled slip), the core springs that never
    slip, which hold a mechanism like a stuck element at every motion; phi: (m,) the elements' scales (m); residual:
    (m,) R / phi;
    mechanisms: (k, m); mechanism_load: (k,) rigid_j^T psi; modal_force: alpha; force: (m,) work row for f."""
    size = 0.0
    largest_motion = 0.0
    for i in range(x.size):
        largest_motion = max(largest_motion, abs(x[i] * phi[i]))
    for i in range(x.size):
        if abs(x[i]) < 1.0 or table[i, MACROSLIP_SLOPE] == 0.0:
            force[i] = (stiffness[i] + core[i]) * x[i] - deficit[i]
        else:
            force[i] = core[i] * x[i] + (table[i, MACROSLIP_SLOPE] - power[i] * table[i, 2] - table[i, STICTION]) * (
                1.0 if x[i] > 0.0 else -1.0)
        size += abs(force[i])
    for j in range(mechanisms.shape[0]):
        size += abs(modal_force * mechanism_load[j])
    worst = 0.0
    for j in range(mechanisms.shape[0]):
        total, floor = -modal_force * mechanism_load[j], 8.0 * EPSILON * modal_force_terms * abs(mechanism_load[j])
        participation = 0.0
        for i in range(x.size):
            participation = max(participation, PARTICIPATION * abs(mechanisms[j, i]))
        for i in range(x.size):
            total += mechanisms[j, i] * force[i]
            uncertainty = abs(residual[i]) + CONDENSATION_ACCURACY * largest_motion / phi[i]  # in scaled slip
            holding = abs(x[i]) < 1.0 + uncertainty or table[i, MACROSLIP_SLOPE] == 0.0
            if abs(mechanisms[j, i]) >= participation:
                floor += abs(mechanisms[j, i]) * ((stiffness[i] if holding else 0.0) + core[i]) * uncertainty
        worst = max(worst, abs(total) - floor)
    return max(worst, 0.0) / max(size, 1e-300)


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _deepest_slip(x):
    """max |x|: the deepest element's slip in slip displacements."""
    deepest = 0.0
    for i in range(x.size):
        deepest = max(deepest, abs(x[i]))
    return deepest


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _solve_level(linear, compliance, phi, table, work, matrix, active, compliance_pinv, pinv_formed, stiffness,
                 core, mechanisms, mechanism_load, joint_shape, stuck_force, amplitude_control):
    """Damped Newton for one design at one level from work[X] (the start) to work[X]; table: the elements'
    ``law_constants`` (m, N_LAW). Returns (status, pinv_formed): C^+ is formed into compliance_pinv (m, m) the
    first time the energy is needed (pinv_formed False until then) and carried from level to level.

    Converged means both: the condensed residual within ACCEPT_TOLERANCE of its largest term, and the element
    forces balancing the load on every mechanism within FORCE_ACCEPT (``_mechanism_imbalance``; stiffness, core,
    mechanisms, mechanism_load as there; the modal force is stuck_force - b^T g under amplitude control, with
    stuck_force = lambda_1 q, and stuck_force itself under force control)."""
    m = linear.size
    x, trial, residual, trial_residual, step = work[X], work[TRIAL], work[RESIDUAL], work[TRIAL_RESIDUAL], work[STEP]
    deficit, slope, potential = work[DEFICIT], work[SLOPE], work[POTENTIAL]
    trial_deficit, trial_slope, trial_potential = work[TRIAL_DEFICIT], work[TRIAL_SLOPE], work[TRIAL_POTENTIAL]
    power, trial_power = work[POWER], work[TRIAL_POWER]
    _evaluate(x, table, deficit, slope, potential, power)
    error, norm = _residual(x, linear, compliance, phi, deficit, residual)
    imbalance = -1.0  # not yet formed at this iterate
    singular = False
    # A full step that halves |R| is taken without the energy, but after REVISITS such steps that set no record
    # (|R| not below the smallest met so far in this level) only those that do: from then on such steps set
    # ever smaller records and the others decrease E, so Newton cannot cycle around a kink of the slip law (e.g.
    # an element next to macroslip whose steps alternate across |x| = 1, the full step from the worst point of
    # the cycle halving |R| back to its best).
    smallest_norm = norm
    revisits = 0
    shift = 0.0
    for _ in range(MAX_ITERATIONS):
        if error <= TARGET_TOLERANCE:
            modal_force, modal_force_terms = _modal_force(stuck_force, joint_shape, deficit, amplitude_control)
            imbalance = _mechanism_imbalance(x, phi, residual, deficit, power, stiffness, core, table, mechanisms,
                                             mechanism_load, modal_force, modal_force_terms, work[FORCE])
            if imbalance <= FORCE_TARGET:
                break
        singular = _newton_step(residual, compliance, phi, slope, step, work[NEWTON_SLOPE], matrix, work[RIGHT], active,
                                x, power, table, shift)
        if singular:
            break
        largest_step, largest_slip = 0.0, 0.0
        for i in range(m):
            largest_step = max(largest_step, abs(step[i]))
            largest_slip = max(largest_slip, abs(x[i]))
        capped = largest_step > STEP_LIMIT * (1.0 + largest_slip)
        if capped:
            for i in range(m):
                step[i] *= STEP_LIMIT * (1.0 + largest_slip) / largest_step
        energy_known = False
        energy, energy_terms, descent = 0.0, 0.0, 0.0
        length = 1.0
        accepted = False
        for _ in range(MAX_HALVINGS):
            for i in range(m):
                trial[i] = x[i] + length * step[i]
            _evaluate(trial, table, trial_deficit, trial_slope, trial_potential, trial_power, x, power)
            trial_error, trial_norm = _residual(trial, linear, compliance, phi, trial_deficit, trial_residual)
            smaller = trial_norm < (1.0 - 1e-4 * length) * norm
            record = trial_norm < smallest_norm
            if (length == 1.0 and not capped and trial_norm <= CONTRACTION * norm and (record or revisits < REVISITS)
                    and _convex_between(x, trial, slope, trial_slope, table)):
                revisits += 0 if record else 1
            else:
                if not energy_known:
                    if not pinv_formed:
                        pseudo_inverse(compliance, compliance_pinv, matrix)
                        pinv_formed = True
                    energy, energy_terms = _energy(x, linear, compliance_pinv, phi, potential)
                    descent = _directional_derivative(step, compliance_pinv, residual, phi)
                    energy_known = True
                trial_energy, _ = _energy(trial, linear, compliance_pinv, phi, trial_potential)
                if abs(trial_energy - energy) <= 1e-12 * energy_terms:
                    # E's change is lost in the round-off of its terms (elements far beyond macroslip, K_T r^2 huge):
                    # E still decreasing at the trial (d/dt E = dx^T C^+ R) means, E convex on the step, below E(x)
                    acceptable = _directional_derivative(step, compliance_pinv, trial_residual, phi) <= 0.0
                else:
                    acceptable = (trial_energy <= energy + 1e-4 * length * min(descent, 0.0)
                                  or smaller and trial_energy <= energy + 1e-12 * energy_terms)
                if not acceptable:
                    length *= 0.5
                    continue
            error, norm, accepted, imbalance = trial_error, trial_norm, True, -1.0
            smallest_norm = min(smallest_norm, norm)
            for i in range(m):
                x[i], residual[i] = trial[i], trial_residual[i]
                deficit[i], slope[i], potential[i] = trial_deficit[i], trial_slope[i], trial_potential[i]
                power[i] = trial_power[i]
            break
        if not accepted:  # no descent along this step (round-off in a near-singular Newton matrix): shift it
            if shift >= MAX_SHIFT:
                break
            shift = max(100.0 * shift, SHIFT)
            continue
        if capped or length < 1.0:
            shift = max(10.0 * shift, SHIFT)
        elif shift > 0.0:
            shift = 0.1 * shift if shift > SHIFT else 0.0
    if error <= ACCEPT_TOLERANCE and _deepest_slip(x) >= POLISH_DEPTH and not _newton_step(
            residual, compliance, phi, slope, step, work[NEWTON_SLOPE], matrix, work[RIGHT], active, x, power, table,
            0.0):
        # polish: one unshifted Newton step from the accepted point, kept where |R| does not grow
        for i in range(m):
            trial[i] = x[i] + step[i]
        _evaluate(trial, table, trial_deficit, trial_slope, trial_potential, trial_power, x, power)
        trial_error, trial_norm = _residual(trial, linear, compliance, phi, trial_deficit, trial_residual)
        if trial_norm <= norm:
            error, norm, imbalance = trial_error, trial_norm, -1.0
            for i in range(m):
                x[i], residual[i] = trial[i], trial_residual[i]
                deficit[i], slope[i], potential[i] = trial_deficit[i], trial_slope[i], trial_potential[i]
                power[i] = trial_power[i]
    if error <= ACCEPT_TOLERANCE:
        if imbalance < 0.0:
            modal_force, modal_force_terms = _modal_force(stuck_force, joint_shape, deficit, amplitude_control)
            imbalance = _mechanism_imbalance(x, phi, residual, deficit, power, stiffness, core, table, mechanisms,
                                             mechanism_load, modal_force, modal_force_terms, work[FORCE])
        if imbalance > FORCE_ACCEPT:
            return UNBALANCED, pinv_formed
        if _sliding_mechanism(x, table, core, mechanisms) and not _newton_resolved(
                residual, compliance, phi, work, matrix, active, x, table):
            return FLAT, pinv_formed
        return CONVERGED, pinv_formed
    beyond_macroslip = True
    for i in range(m):
        if (table[i, MACROSLIP_SLOPE] > 0.0 and linear[i] != 0.0 and abs(x[i]) < 1.0) or core[i] > 0.0:
            beyond_macroslip = False
    return UNRESTRAINED if singular or beyond_macroslip else NOT_CONVERGED, pinv_formed


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _sliding_mechanism(x, table, core, mechanisms):
    """Whether every element taking part in some joint mechanism d_j (``PARTICIPATION``) slides beyond macroslip
    with no core spring (core: K_c phi, 0 where none): then none holds it, each element's force is its constant
    sliding force, and the energy is flat along d_j but for alpha's coupling (amplitude control) and the elements
    entering macroslip."""
    for j in range(mechanisms.shape[0]):
        largest = 0.0
        for i in range(x.size):
            largest = max(largest, abs(mechanisms[j, i]))
        sliding = True
        for i in range(x.size):
            if abs(mechanisms[j, i]) >= PARTICIPATION * largest and (
                    abs(x[i]) <= 1.0 or table[i, MACROSLIP_SLOPE] == 0.0 or core[i] > 0.0):
                sliding = False
                break
        if sliding:
            return True
    return False


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _newton_resolved(residual, compliance, phi, work, matrix, active, x, table):
    """Whether the unshifted Newton step from the iterate x (``_newton_step``, the true slopes where the matrix
    allows) is within STEP_ACCEPT of the largest joint motion: the iterate is then an equilibrium to that
    accuracy whatever the energy's curvature; not where the Newton matrix is singular (a mechanism whose energy
    is flat: no resolved equilibrium). Uses work[STEP], work[NEWTON_SLOPE] and work[RIGHT]."""
    step = work[STEP]
    if _newton_step(residual, compliance, phi, work[SLOPE], step, work[NEWTON_SLOPE], matrix, work[RIGHT], active, x,
                    work[POWER], table, 0.0):
        return False
    largest_step, largest_motion = 0.0, 0.0
    for i in range(x.size):
        largest_step = max(largest_step, abs(step[i] * phi[i]))
        largest_motion = max(largest_motion, abs(x[i] * phi[i]))
    return largest_step <= STEP_ACCEPT * largest_motion


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _regime_changed(x, previous, dropping):
    """Whether an element whose force drops at macroslip (dropping: (m,) bool) is on the other side of macroslip,
    |x| = 1, at x than at the previous equilibrium: its force jumped, and so does the loading path."""
    for i in range(x.size):
        if dropping[i] and (abs(x[i]) > 1.0) != (abs(previous[i]) > 1.0):
            return True
    return False


@numba.njit(cache=True, error_model=ERROR_MODEL)
def _modal_force(stuck_force, joint_shape, deficit, amplitude_control):
    """alpha = lambda_1 q - b^T g under amplitude control (stuck_force = lambda_1 q), else the level itself, and
    the magnitude of its terms (for its round-off)."""
    if not amplitude_control:
        return stuck_force, abs(stuck_force)
    modal_deficit, terms = 0.0, abs(stuck_force)
    for i in range(deficit.size):
        modal_deficit += joint_shape[i] * deficit[i]
        terms += abs(joint_shape[i] * deficit[i])
    return stuck_force - modal_deficit, terms


@numba.njit(cache=True, error_model=ERROR_MODEL)
def solve_levels(levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
                 amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load, defined):
    """All designs, all levels, and their modal backbone.

    levels: (L,) prescribed q (m kg^0.5, amplitude control) or alpha (N kg^-0.5, force control), increasing;
    linear_per_level: (n_designs, m), the linear joint motion per unit level (m); compliance: (n_designs, m, m)
    the stuck structure's tangential compliance C (m/N); the slip forces see C - b b^T / lambda_1 under
    amplitude control (the tracked mode removed, here, design by design), C under force control; phi, r, s,
    chi, theta: (n_designs, m) slip-law constants; stuck: (m,) bool, the linear elements (slip ratio 0);
    eigenvalue: (n_designs,) lambda_1;
    joint_shape: (n_designs, m) b_t; linear_damping: zeta_0; stiffness: (n_designs, m) the elements' stuck
    tangents K_T (N/m); core: (n_designs, m) the core springs K_c in parallel with them (N/m, 0 where none; the
    compliance already holds them); mechanisms: (k, m) the joint's tangential mechanisms d_j and mechanism_load:
    (n_designs, k) rigid_j^T psi (``nonlinear.condensation.joint_mechanisms``), for the force balance on them;
    defined: (n_designs,) bool, False where the stuck mode is not defined (not found, or the stuck structure
    unstable): those designs are not solved (NOT_CONVERGED on every level). Each level starts from the parabola
    through the last three converged levels, or fewer, never across a level that failed (after one, from the last
    converged level scaled to this one); a level that fails from there is solved again from the stuck solution.
    Returns the joint displacements r = phi x (m) and slip ratios |x| (0 where stuck), each
    (n_designs, L, m), status codes (n_designs, L), and amplitude q, force alpha, frequency omega (rad/s),
    damping zeta, each (n_designs, L); NaN where not converged (the prescribed level is kept).
    """
    n_designs, m = linear_per_level.shape
    outputs = level_outputs(n_designs, levels.size, m, stuck)
    workspace = (np.empty((N_WORK_ROWS, m)), np.empty((m, 2 * m)), np.empty((m, m)), np.empty(m), np.zeros(m),
                 np.empty(m, dtype=np.bool_), np.empty((m, m)), np.empty((m, N_LAW)), np.empty(m), np.empty(m),
                 np.empty(m, dtype=np.int64))
    problem = (levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape,
               amplitude_control, linear_damping, stiffness, core, mechanisms, mechanism_load)
    for d in range(n_designs):
        if defined[d]:
            solve_design(d, problem, outputs, workspace)
    return outputs[1:]


@numba.njit(cache=True, error_model=ERROR_MODEL)
def level_outputs(n_designs, n_levels, m, stuck):
    """The arrays ``solve_design`` fills, as a design not solved leaves them: the scaled solutions x, joint
    displacements and slip ratios (n_designs, n_levels, m; NaN, the slip ratio 0 at the stuck elements), status
    codes (n_designs, n_levels; NOT_CONVERGED) and amplitude, force, frequency and damping (n_designs, n_levels;
    NaN)."""
    slip_ratio = np.full((n_designs, n_levels, m), np.nan)
    slip_ratio[:, :, stuck] = 0.0
    return (np.full((n_designs, n_levels, m), np.nan), np.full((n_designs, n_levels, m), np.nan), slip_ratio,
            np.full((n_designs, n_levels), NOT_CONVERGED, dtype=np.int8), np.full((n_designs, n_levels), np.nan),
            np.full((n_designs, n_levels), np.nan), np.full((n_designs, n_levels), np.nan),
            np.full((n_designs, n_levels), np.nan))


@numba.njit(cache=True, error_model=ERROR_MODEL)
def solve_design(d, problem, outputs, workspace):
    """Every level of design d and its modal backbone into row d of ``outputs`` (``level_outputs``).

    problem: the arguments of ``solve_levels`` from levels to mechanism_load, in its order; workspace: this
    design's work arrays, overwritten: the rows of N_WORK_ROWS (N_WORK_ROWS, m), the Newton matrix with its
    right-hand side or C with the identity (m, 2 m), C^+ (m, m), the last equilibrium reached on the loading path
    within a level (m,), the stuck state (m,: zeros), the elements whose force drops at macroslip by more than
    NEGLIGIBLE_DROP (m,: bool), the design's compliance (m, m), its ``law_constants`` (m, N_LAW), K_T phi and
    K_c phi (m,) and the slipping elements' indices (m,: int64). The same source compiles for the CPU
    (``solve_levels``, one workspace for every design) and for CUDA (``nonlinear.qsma_cuda``, one per thread)."""
    (levels, linear_per_level, compliance, phi, r, s, chi, theta, stuck, eigenvalue, joint_shape, amplitude_control,
     linear_damping, stiffness, core, mechanisms, mechanism_load) = problem
    solutions, joint_displacement, slip_ratio, status, amplitude, force, frequency, damping = outputs
    (work, matrix, compliance_pinv, waypoint, stuck_state, dropping, design_compliance, table, stiffness_scaled,
     core_scaled, active) = workspace
    m = linear_per_level.shape[1]
    n_levels = levels.size
    x, linear = work[X], work[LINEAR]
    _law_table(r[d], s[d], chi[d], theta[d], table)
    stiction = False
    for i in range(m):
        dropping[i] = table[i, STICTION] > 0.0 and theta[d, i] < 1.0 - NEGLIGIBLE_DROP
        stiction = stiction or dropping[i]
    for i in range(m):
        stiffness_scaled[i] = stiffness[d, i] * phi[d, i]
        core_scaled[i] = core[d, i] * phi[d, i]
    mode_share = 1.0 / eigenvalue[d] if amplitude_control else 0.0
    for i in range(m):
        for j in range(m):
            design_compliance[i, j] = compliance[d, i, j] - joint_shape[d, i] * joint_shape[d, j] * mode_share
    pinv_formed = np.bool_(False)  # not a literal, which would compile ``_solve_level`` a second time for it
    previous, before, earliest = -1, -1, -1  # the last three converged levels
    lost = False  # whether the loading path jumped or was lost (stiction)
    for level in range(n_levels):
        value = levels[level]
        if amplitude_control:
            amplitude[d, level] = value
        else:
            force[d, level] = value
        if lost:  # the loading path jumped or was lost at an earlier level
            status[d, level] = PAST_JUMP
            continue
        # Start: the parabola through the last three solutions, else the secant through two, else
        # proportional to the level (exact while the joint is stuck), else the linear solution.
        weight_earliest, weight_before, weight_previous = 0.0, 0.0, 0.0
        if earliest >= 0:
            t0, t1, t2 = levels[earliest], levels[before], levels[previous]
            weight_earliest = (value - t1) * (value - t2) / ((t0 - t1) * (t0 - t2))
            weight_before = (value - t0) * (value - t2) / ((t1 - t0) * (t1 - t2))
            weight_previous = (value - t0) * (value - t1) / ((t2 - t0) * (t2 - t1))
        elif before >= 0:
            weight_before = (levels[previous] - value) / (levels[previous] - levels[before])
            weight_previous = 1.0 - weight_before
        elif previous >= 0:
            weight_previous = value / levels[previous]
        for i in range(m):
            linear[i] = linear_per_level[d, i] * value
            if previous < 0:
                x[i] = linear[i] / phi[d, i]
                continue
            x[i] = weight_previous * solutions[d, previous, i]
            if before >= 0:
                x[i] += weight_before * solutions[d, before, i]
            if earliest >= 0:
                x[i] += weight_earliest * solutions[d, earliest, i]
        stuck_force = eigenvalue[d] * value if amplitude_control else value
        last = solutions[d, previous] if previous >= 0 else stuck_state
        if stiction and previous >= 0 and _regime_changed(x, last, dropping):
            code = NOT_CONVERGED  # the start already crossed: straight to the loading path's substeps
        else:
            code, pinv_formed = _solve_level(linear, design_compliance, phi[d], table, work, matrix, active,
                                             compliance_pinv, pinv_formed, stiffness_scaled, core_scaled,
                                             mechanisms, mechanism_load[d], joint_shape[d], stuck_force,
                                             amplitude_control)
        if stiction and (code != CONVERGED or _regime_changed(x, last, dropping)):
            # The loading path: from the last converged level's equilibrium in SUBSTEPS, each from the one
            # before, up to the first that fails or has an element with stiction cross macroslip (from the
            # stuck state, the first level is its own substep).
            code = JUMPED if code == CONVERGED and previous < 0 else code
            for i in range(m):
                waypoint[i] = last[i]
            for k in range(1, SUBSTEPS + 1 if previous >= 0 else 0):
                substep = value if k == SUBSTEPS else levels[previous] * (value / levels[previous]) ** (
                    k / SUBSTEPS)
                for i in range(m):
                    x[i] = waypoint[i]
                    linear[i] = linear_per_level[d, i] * substep
                code, pinv_formed = _solve_level(linear, design_compliance, phi[d], table, work, matrix,
                                                 active, compliance_pinv, pinv_formed, stiffness_scaled,
                                                 core_scaled, mechanisms, mechanism_load[d], joint_shape[d],
                                                 eigenvalue[d] * substep if amplitude_control else substep,
                                                 amplitude_control)
                if code == CONVERGED and _regime_changed(x, waypoint, dropping):
                    code = JUMPED
                if code != CONVERGED:
                    break
                for i in range(m):
                    waypoint[i] = x[i]
            lost = code != CONVERGED
        elif code != CONVERGED and previous >= 0:
            for i in range(m):
                x[i] = linear[i] / phi[d, i]
            code, pinv_formed = _solve_level(linear, design_compliance, phi[d], table, work, matrix, active,
                                             compliance_pinv, pinv_formed, stiffness_scaled, core_scaled,
                                             mechanisms, mechanism_load[d], joint_shape[d], stuck_force,
                                             amplitude_control)
        status[d, level] = code
        if code != CONVERGED:
            earliest, before = -1, -1
            continue
        earliest, before, previous = before, previous, level
        modal_deficit, dissipation = 0.0, 0.0
        for i in range(m):
            solutions[d, level, i] = x[i]
            joint_displacement[d, level, i] = x[i] * phi[d, i]
            if not stuck[i]:
                slip_ratio[d, level, i] = abs(x[i])
            modal_deficit += joint_shape[d, i] * work[DEFICIT, i]
            dissipation += 4.0 * phi[d, i] * (x[i] * work[DEFICIT, i] - 2.0 * work[POTENTIAL, i])
        if amplitude_control:
            force[d, level] = eigenvalue[d] * value - modal_deficit
        else:
            amplitude[d, level] = (value + modal_deficit) / eigenvalue[d]
        omega_squared = force[d, level] / amplitude[d, level]
        frequency[d, level] = math.sqrt(omega_squared)
        damping[d, level] = dissipation / (2.0 * np.pi * amplitude[d, level] ** 2 * omega_squared) + linear_damping
