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

Per design: the static quantities at mu = 0 give the joint-space compliance; the linearisation
S(0) w = delta (I + Z^T F'(0) Z) w (one step of the method of successive linear problems) estimates all low
stuck modes at once, and the one whose shape best matches the reference fixes the branch j; a safeguarded
Newton iteration mu <- mu + sigma_j / (1 + z^T F' z), z = Z w (w the unit eigenvector of sigma_j), then
converges quadratically to its root. Cost per design: a few dozen m x m operations instead of a full
(n_modes x n_modes) eigen-decomposition.
"""

from __future__ import annotations

import numba
import numpy as np

# S(mu) has the stiff joint's and the stiff modes' large stiffnesses in it, so its root is only good to
# about eps times their ratio to mu (up to 1e-7 here): Newton on S stops at ESTIMATE_TOLERANCE (relative
# step) and the compliance form T(mu) f = 0 polishes the root until its Newton step is below
# ROOT_TOLERANCE. T's entries span the joint compliances 1e-14 to 1e-2 m/N, which puts the round-off
# floor of the root near 1e-12 relative.
ESTIMATE_TOLERANCE = 1e-6
ROOT_TOLERANCE = 1e-11
MAX_NEWTON_ITERATIONS = 30
MAX_POLISH_ITERATIONS = 6
JACOBI_TOLERANCE = 1e-15  # off-diagonal over diagonal size at which a Jacobi sweep stops


@numba.njit(cache=True)
def _cholesky(a):
    """Lower Cholesky factor of the symmetric positive definite ``a`` (its lower triangle is read)."""
    n = a.shape[0]
    lower = np.zeros_like(a)
    for j in range(n):
        diagonal = a[j, j]
        for k in range(j):
            diagonal -= lower[j, k] * lower[j, k]
        lower[j, j] = np.sqrt(diagonal)
        for i in range(j + 1, n):
            total = a[i, j]
            for k in range(j):
                total -= lower[i, k] * lower[j, k]
            lower[i, j] = total / lower[j, j]
    return lower


@numba.njit(cache=True)
def _forward(lower, b):
    """L^-1 b for a lower triangular L and b (n, k), in place."""
    n, k = b.shape
    for c in range(k):
        for i in range(n):
            total = b[i, c]
            for j in range(i):
                total -= lower[i, j] * b[j, c]
            b[i, c] = total / lower[i, i]
    return b


@numba.njit(cache=True)
def _backward(lower, b):
    """L^-T b for a lower triangular L and b (n, k), in place."""
    n, k = b.shape
    for c in range(k):
        for i in range(n - 1, -1, -1):
            total = b[i, c]
            for j in range(i + 1, n):
                total -= lower[j, i] * b[j, c]
            b[i, c] = total / lower[i, i]
    return b


@numba.njit(cache=True)
def symmetric_eigen(a):
    """Eigenvalues (ascending) and orthonormal eigenvectors (columns) of a small symmetric matrix by cyclic
    Jacobi rotations (backward error of order eps times the matrix norm)."""
    n = a.shape[0]
    a = a.copy()
    vectors = np.eye(n)
    for _ in range(50):
        off, size = 0.0, 0.0
        for i in range(n):
            size += a[i, i] * a[i, i]
            for j in range(i + 1, n):
                off += a[i, j] * a[i, j]
        if off <= JACOBI_TOLERANCE ** 2 * size or off == 0.0:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                if a[p, q] == 0.0:
                    continue
                angle = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
                tangent = np.sign(angle) / (abs(angle) + np.sqrt(angle * angle + 1.0)) if angle != 0.0 else 1.0
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
    values = np.empty(n)
    for i in range(n):
        values[i] = a[i, i]
    order = np.argsort(values)
    return values[order], vectors[:, order]


@numba.njit(cache=True)
def solve_dense(matrix, rhs):
    """Gaussian elimination with partial pivoting of a small dense system; (solution, singular). Only an
    exactly zero pivot counts as singular (a joint whose slipping elements leave the halves free); an
    ill-conditioned but regular matrix is solved, and the line search judges the step."""
    m = rhs.size
    a = matrix.copy()
    b = rhs.copy()
    for k in range(m):
        pivot = k
        for i in range(k + 1, m):
            if abs(a[i, k]) > abs(a[pivot, k]):
                pivot = i
        if a[pivot, k] == 0.0:
            return b, True
        if pivot != k:
            for j in range(m):
                a[k, j], a[pivot, j] = a[pivot, j], a[k, j]
            b[k], b[pivot] = b[pivot], b[k]
        for i in range(k + 1, m):
            factor = a[i, k] / a[k, k]
            for j in range(k, m):
                a[i, j] -= factor * a[k, j]
            b[i] -= factor * b[k]
    for k in range(m - 1, -1, -1):
        total = b[k]
        for j in range(k + 1, m):
            total -= a[k, j] * b[j]
        b[k] = total / a[k, k]
    return b, False


@numba.njit(cache=True)
def _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_outer):
    """Cholesky factor of X(mu), Z = X^-1 Phi_L (m, n_L) and S(mu) (n_L, n_L).

    high_outer: (m (m+1) / 2, n_E) products Phi_E[i, e] Phi_E[j, e] for i >= j, row-major lower triangle."""
    m, n_low = low_modes.shape
    weights = 1.0 / (high_eigenvalues - mu)
    packed = high_outer @ weights
    flexibility = np.empty((m, m))
    p = 0
    for i in range(m):
        for j in range(i + 1):
            flexibility[i, j] = packed[p]
            flexibility[j, i] = packed[p]
            p += 1
        flexibility[i, i] += inverse_stiffness[i]
    lower = _cholesky(flexibility)
    z = _backward(lower, _forward(lower, low_modes.copy()))
    s = low_modes.T @ z
    for i in range(n_low):
        s[i, i] += low_eigenvalues[i] - mu
    for i in range(n_low):  # exact symmetry for the eigen-solve
        for j in range(i):
            s[i, j] = s[j, i] = 0.5 * (s[i, j] + s[j, i])
    return lower, z, s


@numba.njit(cache=True)
def _branch_root(branch, mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues, high_modes,
                 high_outer):
    """Root of the ``branch``-th smallest eigenvalue of S(mu) in (0, lambda_c), by Newton's method from mu,
    kept inside a bracket by bisection, to ESTIMATE_TOLERANCE. Returns (mu, w (n_L,) unit, z = Z w (m,))."""
    lower_bound = 0.0
    upper_bound = high_eigenvalues.min() if high_eigenvalues.size else np.inf
    if not lower_bound < mu < upper_bound:
        mu = 0.5 * upper_bound if np.isfinite(upper_bound) else 1.0
    for _ in range(MAX_NEWTON_ITERATIONS):
        _, z_all, s = _low_problem(mu, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues,
                                   high_outer)
        sigma, vectors = symmetric_eigen(s)
        w = vectors[:, branch]
        z = z_all @ w
        high = high_modes.T @ z
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


@numba.njit(cache=True)
def _polish(mu, force, inverse_stiffness, eigenvalues, modes, outer):
    """Newton's method on the Rayleigh functional of T(mu) f = 0, T(mu) = K^-1 + Phi (Lambda - mu)^-1 Phi^T
    (m x m, compliances only, so the stiff joint and the stiff modes of the halves add small numbers instead of
    cancelling large ones): f <- T^-1 T' f (inverse iteration), mu <- mu - f^T T f / f^T T' f, with
    T'(mu) = Phi (Lambda - mu)^-2 Phi^T. Quadratic from the S(mu) estimate. Returns (mu, f, converged)."""
    m = force.size
    for _ in range(MAX_POLISH_ITERATIONS):
        weights = 1.0 / (eigenvalues - mu)
        packed = outer @ weights
        compliance = np.empty((m, m))
        p = 0
        for i in range(m):
            for j in range(i + 1):
                compliance[i, j] = compliance[j, i] = packed[p]
                p += 1
            compliance[i, i] += inverse_stiffness[i]
        modal = modes.T @ force
        solution, singular = solve_dense(compliance, modes @ (modal * weights * weights))
        if singular:  # mu is an eigenvalue to the last bit (e.g. a single-DOF joint): keep f
            return mu, force, True
        force = solution
        force /= np.sqrt(np.sum(force ** 2))
        modal = (modes.T @ force) * weights
        step = (force @ (compliance @ force)) / np.sum(modal * modal)
        mu -= step
        if abs(step) <= ROOT_TOLERANCE * mu:
            return mu, force, True
    return mu, force, False


@numba.njit(cache=True)
def _estimate_mac(mu, w, z, low_modes, high_eigenvalues, high_modes, reference_low, reference_high):
    """MAC against the reference of the estimated mode v_L = w, v_E = -(Lambda_E - mu)^-1 Phi_E^T Z w."""
    v_high = -(high_modes.T @ z) / (high_eigenvalues - mu)
    projection = np.sum(w * reference_low) + np.sum(v_high * reference_high)
    return projection ** 2 / (np.sum(w ** 2) + np.sum(v_high ** 2))


@numba.njit(cache=True)
def _mode_shape(mu, force, inverse_stiffness, eigenvalues, modes, reference):
    """Unit mode v = (Lambda - mu)^-1 Phi^T f with a positive projection on the (unit) reference, its MAC,
    and the joint shape b = Phi v = -K^-1 f / |v| (m per unit modal amplitude, without cancellation)."""
    shape = (modes.T @ force) / (eigenvalues - mu)
    norm = np.sqrt(np.sum(shape ** 2))
    projection = np.sum(shape * reference) / norm
    scale = (1.0 if projection >= 0.0 else -1.0) / norm
    return shape * scale, projection ** 2, -inverse_stiffness * force * scale


@numba.njit(cache=True)
def stuck_designs(joint_stiffness, eigenvalues, modes, outer, reference, low, high, unambiguous_mac):
    """Tracked stuck mode and joint-space compliance for every design.

    joint_stiffness: (n_designs, m) stuck tangents k (N/m); eigenvalues (n,) rad^2/s^2, modes Phi (m, n),
    outer (m (m+1) / 2, n) as in ``_low_problem``, reference (n,) unit; low, high: indices of the modes below
    and above the cutoff. Returns eigenvalue mu (n_designs,), unit shape v (n_designs, n), joint shape b
    (n_designs, m), MAC (n_designs,), compliance C = Phi (Lambda + Phi^T K Phi)^-1 Phi^T (n_designs, m, m),
    m/N, and found (n_designs,) bool (False where the root was not found to ROOT_TOLERANCE).

    Compliance, from the static problem at mu = 0 (load p on r; Z0, S0, X0 at mu = 0; W = K^-1 Z0):

        C = K^-1 X0^-1 F(0) + W S0^-1 W^T,

    both terms positive semi-definite (the halves' high-mode flexibility in series with the joint, and the
    low modes' share), so the sum has no cancellation.
    """
    n_designs, m = joint_stiffness.shape
    low_eigenvalues, high_eigenvalues = eigenvalues[low], eigenvalues[high]
    low_modes, high_modes = np.ascontiguousarray(modes[:, low]), np.ascontiguousarray(modes[:, high])
    high_outer = np.ascontiguousarray(outer[:, high])
    reference_low, reference_high = reference[low], reference[high]
    n_low = low.size
    eigenvalue = np.empty(n_designs)
    shape = np.empty((n_designs, eigenvalues.size))
    joint_shape = np.empty((n_designs, m))
    mac = np.empty(n_designs)
    compliance = np.empty((n_designs, m, m))
    found = np.empty(n_designs, dtype=np.bool_)
    static_flexibility = np.zeros((m, m))
    p = 0
    packed = high_outer @ (1.0 / high_eigenvalues)
    for i in range(m):
        for j in range(i + 1):
            static_flexibility[i, j] = static_flexibility[j, i] = packed[p]
            p += 1
    for d in range(n_designs):
        inverse_stiffness = 1.0 / joint_stiffness[d]
        lower, z0, s0 = _low_problem(0.0, inverse_stiffness, low_eigenvalues, low_modes, high_eigenvalues,
                                     high_outer)
        # Compliance.
        series = _backward(lower, _forward(lower, static_flexibility.copy()))
        w0 = z0 * inverse_stiffness[:, None].copy()
        s0_lower = _cholesky(s0)
        low_share = _forward(s0_lower, w0.T.copy())
        for i in range(m):
            for j in range(i + 1):
                value = 0.5 * (inverse_stiffness[i] * series[i, j] + inverse_stiffness[j] * series[j, i])
                for k in range(n_low):
                    value += low_share[k, i] * low_share[k, j]
                compliance[d, i, j] = compliance[d, j, i] = value
        # Estimates of the low stuck modes: S(0) w = delta (I + Z0^T F'(0) Z0) w.
        high0 = (high_modes.T @ z0) / high_eigenvalues[:, None]
        metric_lower = _cholesky(np.eye(n_low) + high0.T @ high0)
        projected = _forward(metric_lower, _forward(metric_lower, s0.copy()).T.copy())
        projected = 0.5 * (projected + projected.T)
        delta, vectors = symmetric_eigen(projected)
        estimates = _backward(metric_lower, vectors.copy())
        best_branch, best_mac = 0, -1.0
        for i in range(n_low):
            w = estimates[:, i] / np.sqrt(np.sum(estimates[:, i] ** 2))
            z = z0 @ w
            candidate_mac = _estimate_mac(max(delta[i], 0.0), w, z, low_modes, high_eigenvalues, high_modes,
                                          reference_low, reference_high)
            if candidate_mac > best_mac:
                best_branch, best_mac = i, candidate_mac
        best_mac = -1.0
        for attempt in range(n_low):  # the best estimate first; if ambiguous, every other branch too
            branch = best_branch if attempt == 0 else attempt - 1 if attempt - 1 < best_branch else attempt
            mu, _, z = _branch_root(branch, delta[branch], inverse_stiffness, low_eigenvalues,
                                               low_modes, high_eigenvalues, high_modes, high_outer)
            mu, force, converged = _polish(mu, -z, inverse_stiffness, eigenvalues, modes, outer)
            v, candidate_mac, b = _mode_shape(mu, force, inverse_stiffness, eigenvalues, modes, reference)
            if candidate_mac > best_mac:
                best_mac = candidate_mac
                eigenvalue[d], shape[d], joint_shape[d] = mu, v, b
                mac[d], found[d] = candidate_mac, converged
            if best_mac >= unambiguous_mac:
                break
    return eigenvalue, shape, joint_shape, mac, compliance, found
