"""Stuck modes of the joined superelement from a small exact eigenproblem (docs/design.md section 5.1), compiled.

Coordinates are the unjoined modes eta of ``nonlinear.condensation.joint_space``: identity mass, stiffness
Lambda = diag(lambda), relative joint translations r = Phi eta (m = 3 n_patches rows). With the stuck joint
tangents K = diag(k) (1e2 to 1e14 N/m) the stuck eigenproblem is

    (Lambda + Phi^T K Phi) v = mu v.

Split the modes at a cutoff lambda_c into the few low modes L (the relative rigid motions of the halves and
any mode of the halves below the cutoff) and the high modes E (lambda_e >= lambda_c). With the joint force
on the halves f = -K Phi v, the high modes respond as v_E = (Lambda_E - mu)^-1 Phi_E^T f and r = -K^-1 f, so

    f = -X(mu)^-1 Phi_L v_L,   X(mu) = K^-1 + F(mu),   F(mu) = Phi_E (Lambda_E - mu)^-1 Phi_E^T,

the joint compliance in series with the frequency-dependent flexibility of the high modes (m x m, positive
definite for mu < lambda_c; a joint stiffness is never added to a modal stiffness). What is left is the
n_L x n_L nonlinear eigenproblem (n_L = 6 for a superelement with free halves)

    S(mu) v_L = 0,   S(mu) = Lambda_L - mu I + Phi_L^T X(mu)^-1 Phi_L,
    dS/dmu = -(I + Z^T F'(mu) Z),   Z = X^-1 Phi_L,   F'(mu) = Phi_E (Lambda_E - mu)^-2 Phi_E^T.

Eliminating first the high modes, then the joint forces, from [[Lambda - mu, Phi^T], [Phi, -K^-1]] (whose
Schur complement is the stuck matrix minus mu) shows by Sylvester's law of inertia that for 0 <= mu <
lambda_c the number of stuck eigenvalues below mu is the number of negative eigenvalues of S(mu). Each
eigenvalue sigma_j(mu) of S decreases strictly (slope <= -1), so the j-th smallest one has exactly one root
in (0, lambda_c) if any, and that root is the j-th stuck eigenvalue: the branch index tracks the mode.

S(mu) itself holds the joint's and the high modes' large stiffnesses (Phi_L^T X^-1 Phi_L reaches 1e15), so
its root is only good to eps times their ratio to mu (about 1e-7). The root is therefore polished in the
bordered form B(mu) x = 0, x = (f, v_L), B = [[X, Phi_L], [Phi_L^T, mu - Lambda_L]] (Schur complement -S),
which holds only compliances and the low modes' offsets lambda_L - mu: its Rayleigh functional x^T B x has
no cancellation beyond eps mu, and the root comes out at round-off (1e-12 to 1e-14 relative).

Per design: the static quantities at mu = 0 give the joint-space compliance; the linearisation
S(0) w = delta (I + Z^T F'(0) Z) w (one step of the method of successive linear problems) estimates all low
stuck modes at once (within 1e-3), and the estimate whose shape best matches the reference is polished.
Only one stuck mode can have a MAC above 0.5, so a polished mode above it is the target; otherwise (veering
modes, one to three per thousand of Table 3's designs) the root of every branch j is found by a safeguarded
Newton iteration mu <- mu + sigma_j / (1 + z^T F' z), z = Z w (w the unit eigenvector of sigma_j), polished,
and the best match kept. Cost per design: a few dozen m x m operations (m = 15) instead of a dense
n_modes x n_modes eigen-decomposition that is, besides, less accurate. The factorisations, solves and the
small eigen-solve are those of ``nonlinear.dense_linear_algebra``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from nonlinear.dense_linear_algebra import (backward_substitute, cholesky, copy_matrix, dot,
                                            forward_substitute, matvec, rmatvec, solve_dense, symmetric_eigen_in_place,
                                            symmetric_solve)

# Newton on S(mu) stops at ESTIMATE_TOLERANCE (relative step; S's own round-off is near 1e-7), the bordered
# polish at ROOT_TOLERANCE, or at FAST_STEP once it converges at least quadratically.
ESTIMATE_TOLERANCE = 1e-6
ROOT_TOLERANCE = 1e-11
FAST_STEP = 1e-7  # a relative step this small and 100 times smaller than the last: the next is below 1e-13
MAX_NEWTON_ITERATIONS = 30
MAX_POLISH_ITERATIONS = 6
# F(mu) takes the high modes above SERIES_FACTOR times the lowest one by the Taylor series
# 1 / (lambda_e - mu) = sum_k mu^k / lambda_e^(k+1) of SERIES_TERMS terms: for |mu| below the lowest high mode
# (every mu the roots and the polish visit: the branch roots are bracketed below it) the truncation is below
# (1 / SERIES_FACTOR)^SERIES_TERMS = 3e-17 of their sum, and F(mu) costs a third of the explicit sum on the beams
# (22 terms instead of 74).
SERIES_FACTOR = 32.0
SERIES_TERMS = 11


class _Work(NamedTuple):
    """Work arrays of ``stuck_design`` (m joint rows, n_L low and n_E high modes), views of ``design_workspace``'s
    stacked arrays."""

    packed: np.ndarray  # F(mu) packed, (m (m+1) / 2,)
    weights: np.ndarray  # 1 / (lambda_E - mu), (n_E,)
    augmented: np.ndarray  # [X(mu), Phi_L, F'(mu) f] for ``_low_problem``, (m, m + n_L + 1)
    z: np.ndarray  # X^-1 Phi_L, (m, n_L)
    s: np.ndarray  # S(mu), (n_L, n_L)
    high: np.ndarray  # (n_E,) high-mode products
    modal: np.ndarray  # (n_E,)
    product: np.ndarray  # (m,) F'(mu) f
    low: np.ndarray  # (n_L,)
    small: np.ndarray  # (n_L, n_L): a copy of S for the pivoted solve, or the eigen-solve's matrix
    vectors: np.ndarray  # (n_L, n_L) eigenvectors
    values: np.ndarray  # (n_L,) eigenvalues
    force: np.ndarray  # (m,) joint force of the polished mode
    v_low: np.ndarray  # (n_L,) its low-mode part
    w: np.ndarray  # (n_L,) unit low-mode vector of a branch
    zw: np.ndarray  # (m,) Z w
    v_high: np.ndarray  # (n_E,) a candidate mode's high-mode part
    b: np.ndarray  # (m,) a candidate's joint shape
    coefficients: np.ndarray  # (SERIES_TERMS + n_E,) the coefficients of ``flexibility_basis``'s rows in F(mu)


# Work arrays of one design stacked by shape (``design_workspace``): how many of each.
JOINT_VECTORS, LOW_VECTORS, HIGH_VECTORS, LOW_MATRICES = 5, 5, 4, 8


@numba.njit(cache=True)
def design_workspace(joint_vectors, low_vectors, high_vectors, low_matrices, packed, augmented, static_augmented,
                     z, high_projection, low_share, coefficients):
    """One design's work arrays for ``stuck_design``, as views of arrays stacked by shape: joint_vectors
    (JOINT_VECTORS, m), low_vectors (LOW_VECTORS, n_L), high_vectors (HIGH_VECTORS, n_E), low_matrices
    (LOW_MATRICES, n_L, n_L), packed (m (m+1) / 2,), augmented (m, m + n_L + 1), static_augmented
    (m, m + n_L + n_rows), z (m, n_L), high_projection (n_L, n_E), low_share (n_L, n_rows), coefficients
    (SERIES_TERMS + n_E,). The same function serves the CPU (one set for every design) and CUDA
    (``nonlinear.qsma_cuda``: each thread its slices)."""
    work = _Work(packed, high_vectors[0], augmented, z, low_matrices[0], high_vectors[1], high_vectors[2],
                 joint_vectors[0], low_vectors[0], low_matrices[1], low_matrices[2], low_vectors[1], joint_vectors[1],
                 low_vectors[2], low_vectors[3], joint_vectors[2], high_vectors[3], joint_vectors[3], coefficients)
    return (work, joint_vectors[4], static_augmented, low_share, low_matrices[3], high_projection, low_matrices[4],
            low_matrices[5], low_matrices[6], low_vectors[4], low_matrices[7])


@numba.njit(cache=True)
def near_modes(high_eigenvalues) -> int:
    """The number of high modes (eigenvalues increasing, rad^2/s^2) below SERIES_FACTOR times the lowest: those
    that F(mu) sums explicitly where the others enter by their series."""
    count = 0
    while count < high_eigenvalues.size and high_eigenvalues[count] < SERIES_FACTOR * high_eigenvalues[0]:
        count += 1
    return count


def flexibility_basis(high_eigenvalues, high_modes) -> np.ndarray:
    """The rows from which F(mu) is one matrix-vector product, (SERIES_TERMS + n_E, m (m+1) / 2), each a packed
    m x m matrix (row-major lower triangle), m/N per unit coefficient: first the far modes' series terms
    G_k = sum_{e far} Phi_e Phi_e^T / lambda_e^(k+1), k = 0 .. SERIES_TERMS - 1, then the products
    Phi_e Phi_e^T of every high mode e. high_eigenvalues (n_E,) increasing, high_modes Phi_E (m, n_E)."""
    rows, columns = np.tril_indices(high_modes.shape[0])
    outer = (high_modes[rows] * high_modes[columns]).T
    far = slice(near_modes(high_eigenvalues), None)
    inverse_powers = high_eigenvalues[far] ** -(np.arange(1.0, SERIES_TERMS + 1.0)[:, None])
    return np.ascontiguousarray(np.vstack([inverse_powers @ outer[far], outer]))


@numba.njit(cache=True)
def _high_flexibility(mu, high_eigenvalues, flexibility, weights, coefficients, packed):
    """F(mu) = Phi_E (Lambda_E - mu)^-1 Phi_E^T packed as its row-major lower triangle (m (m+1) / 2,) into
    ``packed``, m/N, and 1 / (lambda_E - mu) into ``weights``, from ``flexibility_basis``'s rows: for |mu| below
    the lowest high mode the far modes by their series (coefficients mu^k) and the near ones explicitly,
    otherwise every high mode explicitly."""
    n_high = high_eigenvalues.size
    for e in range(n_high):
        weights[e] = 1.0 / (high_eigenvalues[e] - mu)
    if n_high == 0 or not abs(mu) < high_eigenvalues[0]:
        rmatvec(flexibility[SERIES_TERMS:], weights, packed)
        return
    power = 1.0
    for k in range(SERIES_TERMS):
        coefficients[k] = power
        power *= mu
    near = near_modes(high_eigenvalues)
    for e in range(near):
        coefficients[SERIES_TERMS + e] = weights[e]
    rmatvec(flexibility[:SERIES_TERMS + near], coefficients[:SERIES_TERMS + near], packed)


@numba.njit(cache=True)
def _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, packed, augmented, work):
    """Z = X(mu)^-1 Phi_L (m, n_L) and S(mu) (n_L, n_L) into ``work``, from the high modes' flexibility F(mu)
    packed by ``_high_flexibility``. ``augmented`` (m, m + n_L + k) is work space whose last k columns hold
    further right-hand sides (set by the caller), solved against X(mu) alongside (X^-1 times them is left
    there)."""
    m, n_low = low_modes.shape
    z, s = work.z, work.s
    p = 0
    for i in range(m):
        for j in range(i + 1):
            augmented[j, i] = packed[p]
            p += 1
        augmented[i, i] += inverse_stiffness[i]
        for k in range(n_low):
            augmented[i, m + k] = low_modes[i, k]
    symmetric_solve(augmented, m)
    for i in range(m):
        for k in range(n_low):
            z[i, k] = augmented[i, m + k]
    for i in range(n_low):
        for j in range(n_low):
            total = 0.0
            for k in range(m):
                total += low_modes[k, i] * z[k, j]
            s[i, j] = total
    for i in range(n_low):
        s[i, i] += low_eigenvalues[i] - mu
    for i in range(n_low):  # exact symmetry for the eigen-solve
        for j in range(i):
            s[i, j] = s[j, i] = 0.5 * (s[i, j] + s[j, i])


@numba.njit(cache=True)
def _branch_root(branch, mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes,
                 flexibility, work):
    """Root of the ``branch``-th smallest eigenvalue of S(mu) in (0, lambda_c), by Newton's method from mu,
    kept inside a bracket by bisection, to ESTIMATE_TOLERANCE. Returns mu; w (n_L,) unit and z = Z w (m,) in
    work.w, work.zw."""
    lower_bound = 0.0
    upper_bound = high_eigenvalues[0] if high_eigenvalues.size else math.inf  # increasing
    if not lower_bound < mu < upper_bound:
        mu = 0.5 * upper_bound if math.isfinite(upper_bound) else 1.0
    step = 0.0
    last = work.augmented.shape[1] - 1
    for i in range(work.augmented.shape[0]):  # no further right-hand side
        work.augmented[i, last] = 0.0
    for _ in range(MAX_NEWTON_ITERATIONS):
        _high_flexibility(mu, high_eigenvalues, flexibility, work.weights, work.coefficients, work.packed)
        _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, work.packed, work.augmented, work)
        copy_matrix(work.s, work.small)
        symmetric_eigen_in_place(work.small, work.values, work.vectors)
        for k in range(work.w.size):
            work.w[k] = work.vectors[k, branch]
        matvec(work.z, work.w, work.zw)
        rmatvec(high_modes, work.zw, work.high)
        slope = 1.0
        for e in range(high_eigenvalues.size):
            slope += (work.high[e] * work.weights[e]) ** 2
        step = work.values[branch] / slope
        if abs(step) <= ESTIMATE_TOLERANCE * mu:
            break
        if work.values[branch] > 0.0:
            lower_bound = mu
        else:
            upper_bound = mu
        mu += step
        if not lower_bound < mu < upper_bound:
            mu = 0.5 * (lower_bound + upper_bound) if math.isfinite(upper_bound) else 2.0 * lower_bound
    return mu + step


@numba.njit(cache=True)
def _polish(mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility, work):
    """Newton's method on the Rayleigh functional of the bordered form B(mu) x = 0, x = (f, v_L),

        B(mu) = [[X(mu), Phi_L], [Phi_L^T, mu - Lambda_L]],   dB/dmu = [[F'(mu), 0], [0, I]],

    (m + n_L square; its Schur complement on v_L is -S(mu)): x <- B^-1 B' x (inverse iteration, solved through
    the LDL^T factor of X and S), mu <- mu - x^T B x / x^T B' x. B holds only compliances and the low
    modes' stiffness offsets lambda_L - mu: no joint stiffness and no 1 / (lambda - mu) near a pole, so
    x^T B x has no cancellation beyond eps mu. Quadratic from the estimate. x starts from, and ends in,
    work.force and work.v_low. Returns (mu, converged)."""
    m, n_low = low_modes.shape
    force, v_low, weights, high, modal, low = work.force, work.v_low, work.weights, work.high, work.modal, work.low
    product, augmented = work.product, work.augmented
    last_step = math.inf
    for _ in range(MAX_POLISH_ITERATIONS):
        _high_flexibility(mu, high_eigenvalues, flexibility, weights, work.coefficients, work.packed)
        rmatvec(high_modes, force, high)
        for e in range(weights.size):
            high[e] *= weights[e] * weights[e]
        matvec(high_modes, high, product)  # F'(mu) f, also solved against X(mu)
        for i in range(m):
            augmented[i, m + n_low] = product[i]
        _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, work.packed, augmented, work)
        rmatvec(work.z, product, low)
        for k in range(n_low):
            low[k] -= v_low[k]
        copy_matrix(work.s, work.small)
        if solve_dense(work.small, low, n_low):  # mu is a stuck eigenvalue to the last bit (e.g. a single-DOF
            return mu, True                      # joint): keep x
        norm = 0.0
        for i in range(m):
            coupling = 0.0
            for k in range(n_low):
                coupling += work.z[i, k] * low[k]
            force[i] = augmented[i, m + n_low] - coupling
            norm += force[i] * force[i]
        inverse_norm = 1.0 / math.sqrt(norm + dot(low, low))
        for i in range(m):
            force[i] *= inverse_norm
        for k in range(n_low):
            v_low[k] = low[k] * inverse_norm
        rmatvec(high_modes, force, modal)
        for e in range(weights.size):
            modal[e] *= weights[e]
        value = 0.0
        p = 0
        for i in range(m):  # f^T X f + 2 f^T Phi_L v_L, X from the packed lower triangle of F
            total = 0.0
            for j in range(i):
                total += work.packed[p + j] * force[j]
            p += i
            total = 2.0 * total + (work.packed[p] + inverse_stiffness[i]) * force[i]
            p += 1
            for k in range(n_low):
                total += 2.0 * low_modes[i, k] * v_low[k]
            value += force[i] * total
        for k in range(n_low):
            value += (mu - low_eigenvalues[k]) * v_low[k] * v_low[k]
        step = value / (dot(modal, modal) + dot(v_low, v_low))
        mu -= step
        # Converged, or converging so fast (at least quadratically) that the next step would be below round-off.
        if abs(step) <= ROOT_TOLERANCE * mu or (abs(step) <= FAST_STEP * mu and abs(step) <= 1e-2 * abs(last_step)):
            return mu, True
        last_step = step
    return mu, False


@numba.njit(cache=True)
def _high_projection(z, high_modes, projection):
    """Z^T Phi_E (n_L, n_E) into ``projection``: the high modes' share of the joint forces Z (m, n_L), rows
    contiguous."""
    m, n_low = z.shape
    for k in range(n_low):
        for e in range(high_modes.shape[1]):
            projection[k, e] = 0.0
    for k in range(n_low):
        for i in range(m):
            factor = z[i, k]
            for e in range(high_modes.shape[1]):
                projection[k, e] += factor * high_modes[i, e]


@numba.njit(cache=True)
def _estimate_mac(mu, w, high_projection, high_eigenvalues, reference_low, reference_high, v_high):
    """MAC against the reference of the estimated mode v_L = w, v_E = -(Lambda_E - mu)^-1 Phi_E^T Z w (into
    ``v_high``, (n_E,)), from the high modes' projection Z^T Phi_E (n_L, n_E) of ``_high_projection``."""
    projection, norm = 0.0, 0.0
    for k in range(w.size):
        projection += w[k] * reference_low[k]
        norm += w[k] * w[k]
    rmatvec(high_projection, w, v_high)
    for e in range(v_high.size):
        v_high[e] /= mu - high_eigenvalues[e]
        projection += v_high[e] * reference_high[e]
        norm += v_high[e] * v_high[e]
    return projection ** 2 / norm


@numba.njit(cache=True)
def _mode_shape(mu, inverse_stiffness, high_eigenvalues, high_modes, reference_low, reference_high, work):
    """Unit mode (v_L, v_E = (Lambda_E - mu)^-1 Phi_E^T f) with a positive projection on the (unit) reference,
    into work.v_low and work.v_high, and the joint shape b = Phi v = -K^-1 f / |v| (m per unit modal amplitude,
    without cancellation) into work.b, from x = (work.force, work.v_low). Returns the MAC."""
    v_low, v_high = work.v_low, work.v_high
    rmatvec(high_modes, work.force, v_high)
    squares, projection = 0.0, 0.0
    for e in range(v_high.size):
        v_high[e] /= high_eigenvalues[e] - mu
        squares += v_high[e] * v_high[e]
        projection += v_high[e] * reference_high[e]
    for k in range(v_low.size):
        squares += v_low[k] * v_low[k]
        projection += v_low[k] * reference_low[k]
    norm = math.sqrt(squares)
    projection /= norm
    scale = (1.0 if projection >= 0.0 else -1.0) / norm
    for k in range(v_low.size):
        v_low[k] *= scale
    for e in range(v_high.size):
        v_high[e] *= scale
    for i in range(work.b.size):
        work.b[i] = -inverse_stiffness[i] * work.force[i] * scale
    return projection ** 2


@numba.njit(cache=True)
def stuck_designs(joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility,
                  reference_low, reference_high, unambiguous_mac, rows):
    """Tracked stuck mode and joint-space compliance for every design.

    joint_stiffness: (n_designs, m) stuck tangents k (N/m); low_/high_eigenvalues (n_L,), (n_E,) in rad^2/s^2 and
    low_/high_modes Phi_L (m, n_L), Phi_E (m, n_E): the modal data split at the cutoff; flexibility:
    ``flexibility_basis`` of the high modes; reference_low/high: the unit reference mode split alike. Returns the
    eigenvalue mu (n_designs,), the unit shape split as v_L (n_designs, n_L) and v_E (n_designs, n_E), the joint
    shape b (n_designs, m), the MAC (n_designs,), the compliance C = Phi (Lambda + Phi^T K Phi)^-1 Phi^T on the
    joint rows ``rows`` (n_rows,) only (n_designs, n_rows, n_rows), m/N, found (n_designs,) bool (False where the
    root was not found to ROOT_TOLERANCE), and the estimates delta (n_designs, n_L) of the low stuck eigenvalues
    (rad^2/s^2, increasing), whose signs are those of the stuck eigenvalues (S(0) and the stuck matrix have as many
    negative eigenvalues, Sylvester's law of inertia): a negative one is a stuck mode the joint does not hold
    (prestressed halves on too soft a joint), and the design's other outputs are then not defined. Work arrays are
    allocated once per call; each design is ``stuck_design``.

    Compliance, from the static problem at mu = 0 (load p on r; Z0, S0, X0 at mu = 0; W = K^-1 Z0):

        C = K^-1 X0^-1 F(0) + W S0^-1 W^T,

    both terms positive semi-definite (the halves' high-mode flexibility in series with the joint, and the
    low modes' share), so the sum has no cancellation.
    """
    n_designs, m = joint_stiffness.shape
    n_low, n_high = low_modes.shape[1], high_modes.shape[1]
    outputs = stuck_outputs(n_designs, m, n_low, n_high, rows.size)
    workspace = design_workspace(
        np.empty((JOINT_VECTORS, m)), np.empty((LOW_VECTORS, n_low)), np.empty((HIGH_VECTORS, n_high)),
        np.empty((LOW_MATRICES, n_low, n_low)), np.empty(m * (m + 1) // 2), np.empty((m, m + n_low + 1)),
        np.empty((m, m + n_low + rows.size)), np.empty((m, n_low)), np.empty((n_low, n_high)),
        np.empty((n_low, rows.size)), np.empty(SERIES_TERMS + n_high))
    static_packed, static_square, inverse_square = static_flexibility(high_eigenvalues, flexibility, m)
    problem = (joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility,
               reference_low, reference_high, unambiguous_mac, rows, static_packed, static_square, inverse_square)
    stuck_design(0, n_designs, problem, outputs, workspace)
    return outputs


@numba.njit(cache=True)
def stuck_outputs(n_designs, m, n_low, n_high, n_rows):
    """The arrays ``stuck_design`` fills (``stuck_designs``' returns, uninitialised): eigenvalue (n_designs,),
    shape_low (n_designs, n_L), shape_high (n_designs, n_E), joint_shape (n_designs, m), mac (n_designs,),
    compliance (n_designs, n_rows, n_rows), found (n_designs,) bool and the estimates (n_designs, n_L)."""
    return (np.empty(n_designs), np.empty((n_designs, n_low)), np.empty((n_designs, n_high)),
            np.empty((n_designs, m)), np.empty(n_designs), np.empty((n_designs, n_rows, n_rows)),
            np.empty(n_designs, dtype=np.bool_), np.empty((n_designs, n_low)))


@numba.njit(cache=True)
def static_flexibility(high_eigenvalues, flexibility, m):
    """What every design shares at mu = 0: F(0) packed (m (m+1) / 2,) and square (m, m), m/N, and
    1 / lambda_e^2 (n_E,) of the high modes, from ``flexibility_basis``'s rows."""
    n_high = high_eigenvalues.size
    packed, square, inverse_square = np.empty(m * (m + 1) // 2), np.empty((m, m)), np.empty(n_high)
    _high_flexibility(0.0, high_eigenvalues, flexibility, inverse_square, np.empty(SERIES_TERMS + n_high), packed)
    for e in range(n_high):
        inverse_square[e] *= inverse_square[e]
    p = 0
    for i in range(m):
        for j in range(i + 1):
            square[i, j] = square[j, i] = packed[p]
            p += 1
    return packed, square, inverse_square


@numba.njit(cache=True)
def stuck_design(first, last, problem, outputs, workspace):
    """The tracked stuck modes and compliances of designs first to last - 1 into their rows of ``outputs``
    (``stuck_outputs``), one after the other.

    problem: the arguments of ``stuck_designs`` in its order, then ``static_flexibility``'s three arrays;
    workspace: the work arrays (``design_workspace``), overwritten by each design. The same source compiles for the
    CPU (``stuck_designs``: every design, one workspace) and for CUDA (``nonlinear.qsma_cuda``: each thread its
    design, with its own workspace). The arguments are unpacked once for all the designs: per design, it cost the
    CPU 8 % of the stuck modes' time."""
    (joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, flexibility, reference_low,
     reference_high, unambiguous_mac, rows, static_packed, static_square, inverse_square) = problem
    eigenvalue, shape_low, shape_high, joint_shape, mac, compliance, found, low_estimates = outputs
    (work, inverse_stiffness, static_augmented, low_share, s0_factor, high0, metric, metric_factor, projected, delta,
     estimates) = workspace
    m, n_low = low_modes.shape
    n_high, n_rows = high_modes.shape[1], rows.size
    for d in range(first, last):
        for i in range(m):
            inverse_stiffness[i] = 1.0 / joint_stiffness[d, i]
        for i in range(m):
            for b in range(n_rows):
                static_augmented[i, m + n_low + b] = static_square[i, rows[b]]
        _low_problem(0.0, inverse_stiffness, low_eigenvalues, low_modes, static_packed, static_augmented, work)
        z0, s0 = work.z, work.s
        # Compliance (X0^-1 F(0) on the rows in static_augmented's last columns).
        cholesky(s0, s0_factor)
        for k in range(n_low):
            for b in range(n_rows):
                low_share[k, b] = z0[rows[b], k] * inverse_stiffness[rows[b]]
        forward_substitute(s0_factor, low_share)
        for a in range(n_rows):
            i = rows[a]
            for b in range(a + 1):
                j = rows[b]
                value = 0.5 * (inverse_stiffness[i] * static_augmented[i, m + n_low + b]
                               + inverse_stiffness[j] * static_augmented[j, m + n_low + a])
                for k in range(n_low):
                    value += low_share[k, a] * low_share[k, b]
                compliance[d, a, b] = compliance[d, b, a] = value
        # Estimates of the low stuck modes: S(0) w = delta (I + Z0^T F'(0) Z0) w.
        _high_projection(z0, high_modes, high0)
        for k in range(n_low):  # I + Z0^T F'(0) Z0 = I + sum_e (Phi_e^T Z0)^T (Phi_e^T Z0) / lambda_e^2
            for j in range(n_low):
                total = 1.0 if k == j else 0.0
                for e in range(n_high):
                    total += high0[k, e] * high0[j, e] * inverse_square[e]
                metric[k, j] = total
        cholesky(metric, metric_factor)
        copy_matrix(s0, projected)
        forward_substitute(metric_factor, projected)
        for k in range(n_low):
            for j in range(n_low):
                work.small[k, j] = projected[j, k]
        forward_substitute(metric_factor, work.small)
        for k in range(n_low):
            for j in range(k + 1):
                work.small[k, j] = work.small[j, k] = 0.5 * (work.small[k, j] + work.small[j, k])
        symmetric_eigen_in_place(work.small, delta, estimates)
        for k in range(n_low):
            low_estimates[d, k] = delta[k]
        backward_substitute(metric_factor, estimates)
        best_branch, best_mac = 0, -1.0
        for i in range(n_low):
            norm = 0.0
            for k in range(n_low):
                norm += estimates[k, i] * estimates[k, i]
            for k in range(n_low):
                work.w[k] = estimates[k, i] / math.sqrt(norm)
            candidate_mac = _estimate_mac(max(delta[i], 0.0), work.w, high0, high_eigenvalues, reference_low,
                                          reference_high, work.v_high)
            if candidate_mac > best_mac:
                best_branch, best_mac = i, candidate_mac
        # The estimate is within about 1e-3: polish it directly. Only one stuck mode can have a MAC above 0.5,
        # so if the polished mode does, it is the target whatever path led to it. Otherwise solve every branch
        # safely (Newton on sigma_j in its bracket, then polish) and keep the best match.
        best_mac = -1.0
        for attempt in range(-1, n_low if n_low > 1 else 0):
            branch = best_branch if attempt < 0 else attempt
            if attempt < 0:  # Z0 w, the static joint force of the estimate (work.z still holds Z0)
                norm = 0.0
                for k in range(n_low):
                    norm += estimates[k, branch] * estimates[k, branch]
                for k in range(n_low):
                    work.w[k] = estimates[k, branch] / math.sqrt(norm)
                matvec(work.z, work.w, work.zw)
                mu = delta[branch]
            else:
                mu = _branch_root(branch, delta[branch], inverse_stiffness, low_eigenvalues, low_modes,
                                  high_eigenvalues, high_modes, flexibility, work)
            for i in range(m):
                work.force[i] = -work.zw[i]
            for k in range(work.w.size):
                work.v_low[k] = work.w[k]
            mu, converged = _polish(mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues,
                                    high_modes, flexibility, work)
            candidate_mac = _mode_shape(mu, inverse_stiffness, high_eigenvalues, high_modes, reference_low,
                                        reference_high, work)
            if candidate_mac > best_mac:
                best_mac = candidate_mac
                eigenvalue[d], mac[d], found[d] = mu, candidate_mac, converged
                for k in range(n_low):
                    shape_low[d, k] = work.v_low[k]
                for e in range(n_high):
                    shape_high[d, e] = work.v_high[e]
                for i in range(m):
                    joint_shape[d, i] = work.b[i]
            if best_mac >= unambiguous_mac:
                break
