"""Stuck modes of the joined superelement from a small exact eigenproblem (DESIGN.md section 5.1), compiled.

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
n_modes x n_modes eigen-decomposition that is, besides, less accurate.
"""

from __future__ import annotations

import numba
import numpy as np

# Newton on S(mu) stops at ESTIMATE_TOLERANCE (relative step; S's own round-off is near 1e-7), the bordered
# polish at ROOT_TOLERANCE, or at FAST_STEP once it converges at least quadratically.
# Floating-point reassociation and fused multiply-adds (never assumptions about NaN or infinity): lets the
# compiler vectorise the small reductions; results change only in the last bits.
FAST_MATH = {"reassoc", "contract", "arcp"}
ESTIMATE_TOLERANCE = 1e-6
ROOT_TOLERANCE = 1e-11
FAST_STEP = 1e-7  # a relative step this small and 100 times smaller than the last: the next is below 1e-13
MAX_NEWTON_ITERATIONS = 30
MAX_POLISH_ITERATIONS = 6
JACOBI_TOLERANCE = 1e-16  # off-diagonal entries below this times the matrix norm are left alone
MAX_JACOBI_SWEEPS = 30


@numba.njit(cache=True, fastmath=FAST_MATH)
def _dot(x, y):
    """x . y of two vectors (a loop: no temporary array)."""
    total = 0.0
    for i in range(x.size):
        total += x[i] * y[i]
    return total


@numba.njit(cache=True, fastmath=FAST_MATH)
def _matvec(a, x):
    """a x for a small dense matrix (plain loops: BLAS calls cost more than the work at these sizes)."""
    rows, columns = a.shape
    out = np.zeros(rows)
    for i in range(rows):
        total = 0.0
        for j in range(columns):
            total += a[i, j] * x[j]
        out[i] = total
    return out


@numba.njit(cache=True, fastmath=FAST_MATH)
def _rmatvec(a, x):
    """a^T x for a small dense matrix."""
    rows, columns = a.shape
    out = np.zeros(columns)
    for i in range(rows):
        xi = x[i]
        for j in range(columns):
            out[j] += a[i, j] * xi
    return out


@numba.njit(cache=True, fastmath=FAST_MATH)
def _cholesky(a):
    """Cholesky factor of the symmetric positive definite ``a`` (its upper triangle is read), stored as the
    upper triangular U = L^T (A = U^T U), row by row with right-looking updates along rows (contiguous)."""
    n = a.shape[0]
    upper = np.zeros_like(a)
    for i in range(n):
        for j in range(i, n):
            upper[i, j] = a[i, j]
    for j in range(n):
        inverse = 1.0 / np.sqrt(upper[j, j])
        for i in range(j, n):
            upper[j, i] *= inverse
        for k in range(j + 1, n):
            factor = upper[j, k]
            for i in range(k, n):
                upper[k, i] -= factor * upper[j, i]
    return upper


@numba.njit(cache=True, fastmath=FAST_MATH)
def _forward(upper, b):
    """U^-T b (= L^-1 b) for the factor of ``_cholesky`` and b (n, k), in place (all right-hand sides in the
    inner loop)."""
    n, k = b.shape
    for i in range(n):
        for j in range(i):
            factor = upper[j, i]
            for c in range(k):
                b[i, c] -= factor * b[j, c]
        inverse = 1.0 / upper[i, i]
        for c in range(k):
            b[i, c] *= inverse
    return b


@numba.njit(cache=True, fastmath=FAST_MATH)
def _backward(upper, b):
    """U^-1 b (= L^-T b) for the factor of ``_cholesky`` and b (n, k), in place."""
    n, k = b.shape
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            factor = upper[i, j]
            for c in range(k):
                b[i, c] -= factor * b[j, c]
        inverse = 1.0 / upper[i, i]
        for c in range(k):
            b[i, c] *= inverse
    return b


@numba.njit(cache=True, fastmath=FAST_MATH)
def symmetric_eigen(a):
    """Eigenvalues (ascending) and orthonormal eigenvectors (columns) of a small symmetric matrix by cyclic
    Jacobi rotations, until every off-diagonal entry is below JACOBI_TOLERANCE times the matrix norm
    (backward error of order eps times the norm)."""
    n = a.shape[0]
    a = a.copy()
    vectors = np.eye(n)
    threshold = JACOBI_TOLERANCE * np.sqrt(np.sum(a * a))
    for _ in range(MAX_JACOBI_SWEEPS):
        rotated = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                if abs(a[p, q]) <= threshold:
                    continue
                rotated = True
                angle = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
                tangent = (1.0 if angle >= 0.0 else -1.0) / (abs(angle) + np.sqrt(angle * angle + 1.0))
                cosine = 1.0 / np.sqrt(tangent * tangent + 1.0)
                sine = tangent * cosine
                for k in range(n):
                    akp, akq = a[k, p], a[k, q]
                    a[k, p], a[k, q] = cosine * akp - sine * akq, sine * akp + cosine * akq
                for k in range(n):
                    apk, aqk = a[p, k], a[q, k]
                    a[p, k], a[q, k] = cosine * apk - sine * aqk, sine * apk + cosine * aqk
                for k in range(n):
                    vkp, vkq = vectors[k, p], vectors[k, q]
                    vectors[k, p], vectors[k, q] = cosine * vkp - sine * vkq, sine * vkp + cosine * vkq
                a[p, q] = a[q, p] = 0.0
        if not rotated:
            break
    values = np.empty(n)
    for i in range(n):
        values[i] = a[i, i]
    order = np.argsort(values)
    return values[order], vectors[:, order]


@numba.njit(cache=True, fastmath=FAST_MATH)
def solve_dense(a, b, n):
    """Gaussian elimination with partial pivoting of the leading n x n block of ``a`` against b[:n], both
    overwritten (the solution in b[:n]); returns True if singular. Only an exactly zero pivot counts as
    singular (e.g. a joint whose slipping elements leave the halves free); an ill-conditioned but regular
    matrix is solved, and the caller judges the result."""
    for k in range(n):
        pivot = k
        for i in range(k + 1, n):
            if abs(a[i, k]) > abs(a[pivot, k]):
                pivot = i
        if a[pivot, k] == 0.0:
            return True
        if pivot != k:
            for j in range(n):
                a[k, j], a[pivot, j] = a[pivot, j], a[k, j]
            b[k], b[pivot] = b[pivot], b[k]
        for i in range(k + 1, n):
            factor = a[i, k] / a[k, k]
            for j in range(k, n):
                a[i, j] -= factor * a[k, j]
            b[i] -= factor * b[k]
    back_substitute(a, b, n)
    return False


@numba.njit(cache=True, fastmath=FAST_MATH)
def back_substitute(upper, b, n):
    """Solve the leading n x n upper-triangular block of ``upper`` against b[:n], in place in b."""
    for k in range(n - 1, -1, -1):
        total = b[k]
        for j in range(k + 1, n):
            total -= upper[k, j] * b[j]
        b[k] = total / upper[k, k]


@numba.njit(cache=True, fastmath=FAST_MATH)
def _high_flexibility(mu, high_eigenvalues, high_outer):
    """F(mu) = Phi_E (Lambda_E - mu)^-1 Phi_E^T packed as its row-major lower triangle (m (m+1) / 2,), m/N.

    high_outer: (n_E, m (m+1) / 2) products Phi_E[i, e] Phi_E[j, e] for i >= j, row-major lower triangle."""
    return _rmatvec(high_outer, 1.0 / (high_eigenvalues - mu))


@numba.njit(cache=True, fastmath=FAST_MATH)
def _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, packed):
    """X(mu) (m, m), its Cholesky factor, Z = X^-1 Phi_L (m, n_L) and S(mu) (n_L, n_L), from the high modes'
    flexibility F(mu) packed by ``_high_flexibility``."""
    m, n_low = low_modes.shape
    flexibility = np.empty((m, m))
    p = 0
    for i in range(m):
        for j in range(i + 1):
            flexibility[i, j] = packed[p]
            flexibility[j, i] = packed[p]
            p += 1
        flexibility[i, i] += inverse_stiffness[i]
    factor = _cholesky(flexibility)
    z = _backward(factor, _forward(factor, low_modes.copy()))
    s = np.empty((n_low, n_low))
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
    return flexibility, factor, z, s


@numba.njit(cache=True, fastmath=FAST_MATH)
def _branch_root(branch, mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes,
                 high_outer):
    """Root of the ``branch``-th smallest eigenvalue of S(mu) in (0, lambda_c), by Newton's method from mu,
    kept inside a bracket by bisection, to ESTIMATE_TOLERANCE. Returns (mu, w (n_L,) unit, z = Z w (m,))."""
    lower_bound = 0.0
    upper_bound = high_eigenvalues.min() if high_eigenvalues.size else np.inf
    if not lower_bound < mu < upper_bound:
        mu = 0.5 * upper_bound if np.isfinite(upper_bound) else 1.0
    for _ in range(MAX_NEWTON_ITERATIONS):
        _, _, z_all, s = _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes,
                                      _high_flexibility(mu, high_eigenvalues, high_outer))
        sigma, vectors = symmetric_eigen(s)
        w = vectors[:, branch]
        z = _matvec(z_all, w)
        high = _rmatvec(high_modes, z)
        slope = 1.0 + np.sum((high / (high_eigenvalues - mu)) ** 2)
        step = sigma[branch] / slope
        if abs(step) <= ESTIMATE_TOLERANCE * mu:
            break
        if sigma[branch] > 0.0:
            lower_bound = mu
        else:
            upper_bound = mu
        mu += step
        if not lower_bound < mu < upper_bound:
            mu = 0.5 * (lower_bound + upper_bound) if np.isfinite(upper_bound) else 2.0 * lower_bound
    return mu + step, w, z


@numba.njit(cache=True, fastmath=FAST_MATH)
def _polish(mu, force, v_low, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes,
            high_outer):
    """Newton's method on the Rayleigh functional of the bordered form B(mu) x = 0, x = (f, v_L),

        B(mu) = [[X(mu), Phi_L], [Phi_L^T, mu - Lambda_L]],   dB/dmu = [[F'(mu), 0], [0, I]],

    (m + n_L square; its Schur complement on v_L is -S(mu)): x <- B^-1 B' x (inverse iteration, solved through
    the Cholesky factor of X and S), mu <- mu - x^T B x / x^T B' x. B holds only compliances and the low
    modes' stiffness offsets lambda_L - mu: no joint stiffness and no 1 / (lambda - mu) near a pole, so
    x^T B x has no cancellation beyond eps mu. Quadratic from the estimate. Returns (mu, f, v_L, converged)."""
    m, n_low = low_modes.shape
    last_step = np.inf
    for _ in range(MAX_POLISH_ITERATIONS):
        flexibility, factor, z, s = _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes,
                                                _high_flexibility(mu, high_eigenvalues, high_outer))
        weights = 1.0 / (high_eigenvalues - mu)
        high = _rmatvec(high_modes, force)
        for e in range(weights.size):
            high[e] *= weights[e] * weights[e]
        rhs = _matvec(high_modes, high)
        solution_low = _rmatvec(z, rhs)
        for k in range(n_low):
            solution_low[k] -= v_low[k]
        if solve_dense(s, solution_low, n_low):  # mu is a stuck eigenvalue to the last bit (e.g. a single-DOF
            return mu, force, v_low, True        # joint): keep x
        solution = _backward(factor, _forward(factor, rhs.reshape((m, 1))))[:, 0]
        coupling = _matvec(z, solution_low)
        for i in range(m):
            solution[i] -= coupling[i]
        inverse_norm = 1.0 / np.sqrt(_dot(solution, solution) + _dot(solution_low, solution_low))
        force, v_low = solution * inverse_norm, solution_low * inverse_norm
        modal = _rmatvec(high_modes, force)
        for e in range(weights.size):
            modal[e] *= weights[e]
        value = _dot(force, _matvec(flexibility, force)) + 2.0 * _dot(force, _matvec(low_modes, v_low))
        for k in range(n_low):
            value += (mu - low_eigenvalues[k]) * v_low[k] * v_low[k]
        step = value / (_dot(modal, modal) + _dot(v_low, v_low))
        mu -= step
        # Converged, or converging so fast (at least quadratically) that the next step would be below round-off.
        if abs(step) <= ROOT_TOLERANCE * mu or (abs(step) <= FAST_STEP * mu and abs(step) <= 1e-2 * abs(last_step)):
            return mu, force, v_low, True
        last_step = step
    return mu, force, v_low, False


@numba.njit(cache=True, fastmath=FAST_MATH)
def _high_projection(z, high_modes):
    """Z^T Phi_E (n_L, n_E): the high modes' share of the joint forces Z (m, n_L), rows contiguous."""
    m, n_low = z.shape
    projection = np.zeros((n_low, high_modes.shape[1]))
    for k in range(n_low):
        for i in range(m):
            factor = z[i, k]
            for e in range(high_modes.shape[1]):
                projection[k, e] += factor * high_modes[i, e]
    return projection


@numba.njit(cache=True, fastmath=FAST_MATH)
def _estimate_mac(mu, w, high_projection, high_eigenvalues, reference_low, reference_high):
    """MAC against the reference of the estimated mode v_L = w, v_E = -(Lambda_E - mu)^-1 Phi_E^T Z w, from the
    high modes' projection Z^T Phi_E (n_L, n_E) of ``_high_projection``."""
    v_high = -_rmatvec(high_projection, w) / (high_eigenvalues - mu)
    projection = np.sum(w * reference_low) + np.sum(v_high * reference_high)
    return projection ** 2 / (np.sum(w ** 2) + np.sum(v_high ** 2))


@numba.njit(cache=True, fastmath=FAST_MATH)
def _mode_shape(mu, force, v_low, inverse_stiffness, high_eigenvalues, high_modes, reference_low, reference_high):
    """Unit mode (v_L, v_E = (Lambda_E - mu)^-1 Phi_E^T f) with a positive projection on the (unit) reference,
    its MAC, and the joint shape b = Phi v = -K^-1 f / |v| (m per unit modal amplitude, without
    cancellation)."""
    v_high = _rmatvec(high_modes, force) / (high_eigenvalues - mu)
    norm = np.sqrt(np.sum(v_low ** 2) + np.sum(v_high ** 2))
    projection = (np.sum(v_low * reference_low) + np.sum(v_high * reference_high)) / norm
    scale = (1.0 if projection >= 0.0 else -1.0) / norm
    return v_low * scale, v_high * scale, projection ** 2, -inverse_stiffness * force * scale


@numba.njit(cache=True, fastmath=FAST_MATH)
def stuck_designs(joint_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes, high_outer,
                  reference_low, reference_high, unambiguous_mac):
    """Tracked stuck mode and joint-space compliance for every design.

    joint_stiffness: (n_designs, m) stuck tangents k (N/m); low_/high_eigenvalues (n_L,), (n_E,) in
    rad^2/s^2 and low_/high_modes Phi_L (m, n_L), Phi_E (m, n_E): the modal data split at the cutoff;
    high_outer as in ``_high_flexibility``; reference_low/high: the unit reference mode split alike. Returns the
    eigenvalue mu (n_designs,), the unit shape split as v_L (n_designs, n_L) and v_E (n_designs, n_E), the
    joint shape b (n_designs, m), the MAC (n_designs,), the compliance C = Phi (Lambda + Phi^T K Phi)^-1 Phi^T
    (n_designs, m, m), m/N, and found (n_designs,) bool (False where the root was not found to
    ROOT_TOLERANCE).

    Compliance, from the static problem at mu = 0 (load p on r; Z0, S0, X0 at mu = 0; W = K^-1 Z0):

        C = K^-1 X0^-1 F(0) + W S0^-1 W^T,

    both terms positive semi-definite (the halves' high-mode flexibility in series with the joint, and the
    low modes' share), so the sum has no cancellation.
    """
    n_designs, m = joint_stiffness.shape
    n_low, n_high = low_modes.shape[1], high_modes.shape[1]
    eigenvalue = np.empty(n_designs)
    shape_low = np.empty((n_designs, n_low))
    shape_high = np.empty((n_designs, n_high))
    joint_shape = np.empty((n_designs, m))
    mac = np.empty(n_designs)
    compliance = np.empty((n_designs, m, m))
    found = np.empty(n_designs, dtype=np.bool_)
    static_flexibility = np.zeros((m, m))
    p = 0
    static_packed = _high_flexibility(0.0, high_eigenvalues, high_outer)
    inverse_square = 1.0 / high_eigenvalues ** 2
    for i in range(m):
        for j in range(i + 1):
            static_flexibility[i, j] = static_flexibility[j, i] = static_packed[p]
            p += 1
    for d in range(n_designs):
        inverse_stiffness = 1.0 / joint_stiffness[d]
        _, factor, z0, s0 = _low_problem(0.0, inverse_stiffness, low_eigenvalues, low_modes, static_packed)
        # Compliance.
        series = _backward(factor, _forward(factor, static_flexibility.copy()))
        low_share = _forward(_cholesky(s0), (z0 * inverse_stiffness.reshape((m, 1))).T.copy())
        for i in range(m):
            for j in range(i + 1):
                value = 0.5 * (inverse_stiffness[i] * series[i, j] + inverse_stiffness[j] * series[j, i])
                for k in range(n_low):
                    value += low_share[k, i] * low_share[k, j]
                compliance[d, i, j] = compliance[d, j, i] = value
        # Estimates of the low stuck modes: S(0) w = delta (I + Z0^T F'(0) Z0) w.
        high0 = _high_projection(z0, high_modes)
        metric = np.eye(n_low)  # I + Z0^T F'(0) Z0 = I + sum_e (Phi_e^T Z0)^T (Phi_e^T Z0) / lambda_e^2
        for k in range(n_low):
            for j in range(n_low):
                for e in range(n_high):
                    metric[k, j] += high0[k, e] * high0[j, e] * inverse_square[e]
        metric_factor = _cholesky(metric)
        projected = _forward(metric_factor, _forward(metric_factor, s0.copy()).T.copy())
        delta, vectors = symmetric_eigen(0.5 * (projected + projected.T))
        estimates = _backward(metric_factor, vectors.copy())
        best_branch, best_mac = 0, -1.0
        for i in range(n_low):
            w = estimates[:, i] / np.sqrt(np.sum(estimates[:, i] ** 2))
            candidate_mac = _estimate_mac(max(delta[i], 0.0), w, high0, high_eigenvalues, reference_low,
                                          reference_high)
            if candidate_mac > best_mac:
                best_branch, best_mac = i, candidate_mac
        # The estimate is within about 1e-3: polish it directly. Only one stuck mode can have a MAC above 0.5,
        # so if the polished mode does, it is the target whatever path led to it. Otherwise solve every branch
        # safely (Newton on sigma_j in its bracket, then polish) and keep the best match.
        best_mac = -1.0
        for attempt in range(-1, n_low if n_low > 1 else 0):
            branch = best_branch if attempt < 0 else attempt
            w = estimates[:, branch] / np.sqrt(np.sum(estimates[:, branch] ** 2))
            mu, z = delta[branch], _matvec(z0, w)
            if attempt >= 0:
                mu, w, z = _branch_root(branch, mu, inverse_stiffness, low_eigenvalues, low_modes,
                                        high_eigenvalues, high_modes, high_outer)
            mu, force, v_low, converged = _polish(mu, -z, w.copy(), inverse_stiffness, low_eigenvalues, low_modes,
                                                  high_eigenvalues, high_modes, high_outer)
            v_low, v_high, candidate_mac, b = _mode_shape(mu, force, v_low, inverse_stiffness, high_eigenvalues,
                                                          high_modes, reference_low, reference_high)
            if candidate_mac > best_mac:
                best_mac = candidate_mac
                eigenvalue[d], shape_low[d], shape_high[d], joint_shape[d] = mu, v_low, v_high, b
                mac[d], found[d] = candidate_mac, converged
            if best_mac >= unambiguous_mac:
                break
    return eigenvalue, shape_low, shape_high, joint_shape, mac, compliance, found
