"""The compiled small dense linear algebra (``nonlinear.dense_linear_algebra``) against numpy/scipy.

Matrices of the joint problems' sizes (n = 6 to 15) with prescribed spectra: well conditioned, and ill
conditioned (condition numbers 1e8 and 1e12, the range of the joint-space flexibilities X(mu)). Every routine
is backward stable, so a residual is bounded by c n eps |A| whatever the conditioning, and a computed solution
or factor differs from LAPACK's by c n eps cond(A) at most (two backward-stable results, each within that of
the exact one). The factor c = 10 covers the growth constants of the textbook bounds (Golub & Van Loan 3.4,
4.1, 4.2, 8.5) at these sizes; the measured errors stay 7 to 1000 times below the bounds.
"""

import numpy as np
import pytest
import scipy.linalg

from nonlinear.dense_linear_algebra import (backward_substitute, back_substitute, cholesky, dot, forward_substitute,
                                            ldl_back_substitute, ldl_eliminate, matvec, rmatvec, solve_dense,
                                            symmetric_eigen, symmetric_solve)

EPS = np.finfo(float).eps
SAFETY = 10.0  # growth constant of the backward error bounds at n <= 15
SIZES = (6, 15)
CONDITIONS = (1e1, 1e8, 1e12)


def spectrum_matrix(eigenvalues, rng):
    """Symmetric matrix Q diag(eigenvalues) Q^T with a random orthogonal Q (exactly symmetric)."""
    q, _ = np.linalg.qr(rng.standard_normal((eigenvalues.size, eigenvalues.size)))
    a = (q * eigenvalues) @ q.T
    return 0.5 * (a + a.T)


def positive_definite(n, condition, rng):
    """Symmetric positive definite matrix of 2-norm 1 and the given condition number (log-spaced spectrum)."""
    return spectrum_matrix(np.geomspace(1.0 / condition, 1.0, n)[rng.permutation(n)], rng)


def indefinite(n, condition, rng):
    """Symmetric indefinite matrix of 2-norm 1 and the given condition number (both signs in the spectrum)."""
    magnitudes = np.geomspace(1.0 / condition, 1.0, n)
    signs = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    return spectrum_matrix((signs * magnitudes)[rng.permutation(n)], rng)


def bound(n, condition=1.0):
    """Relative error bound c n eps cond of a backward-stable solve (condition 1: a residual or backward error)."""
    return SAFETY * n * EPS * condition


def cases():
    return [(n, condition, seed) for n in SIZES for condition in CONDITIONS for seed in range(3)]


@pytest.mark.parametrize("n, condition, seed", cases())
def test_cholesky_factor_reproduces_the_matrix_and_matches_lapack(n, condition, seed):
    rng = np.random.default_rng(seed)
    a = positive_definite(n, condition, rng)
    lower_triangle_garbage = a + np.tril(rng.standard_normal((n, n)), -1)  # only the upper triangle is read
    upper = cholesky(lower_triangle_garbage, np.full((n, n), np.nan))
    assert np.array_equal(np.tril(upper, -1), np.zeros((n, n)))
    # Backward error |U^T U - A| / |A| ~ n eps, independent of the conditioning.
    assert np.linalg.norm(upper.T @ upper - a, 2) <= bound(n) * np.linalg.norm(a, 2)
    # Forward error of the factor: a backward error of n eps |A| moves the Cholesky factor by at most about
    # cond(A) n eps relatively (first-order perturbation bound, Higham, Accuracy and Stability, Thm 10.8).
    reference = scipy.linalg.cholesky(a, lower=False)
    assert np.linalg.norm(upper - reference, 2) <= bound(n, condition) * np.linalg.norm(reference, 2)


@pytest.mark.parametrize("n, condition, seed", cases())
def test_triangular_solves_with_the_cholesky_factor_solve_the_system(n, condition, seed):
    rng = np.random.default_rng(seed)
    a = positive_definite(n, condition, rng)
    b = rng.standard_normal((n, 3))
    upper = cholesky(a, np.empty((n, n)))
    x = backward_substitute(upper, forward_substitute(upper, b.copy()))
    reference = scipy.linalg.solve(a, b, assume_a="pos")
    assert np.linalg.norm(x - reference) <= bound(n, condition) * np.linalg.norm(reference)
    # Each triangular solve alone against scipy's (triangular systems are solved to their own condition).
    y = forward_substitute(upper, b.copy())
    reference_y = scipy.linalg.solve_triangular(upper, b, trans="T", lower=False)
    assert np.linalg.norm(y - reference_y) <= bound(n, np.linalg.cond(upper)) * np.linalg.norm(reference_y)


def test_cholesky_of_an_indefinite_matrix_is_not_finite():
    """No flag: a non-positive pivot gives the square root of a negative number, NaN, which propagates."""
    a = indefinite(6, 1e2, np.random.default_rng(0))
    assert not np.isfinite(cholesky(a, np.empty((6, 6)))).all()


@pytest.mark.parametrize("n, condition, seed", cases())
def test_ldl_elimination_and_symmetric_solve_match_lapack(n, condition, seed):
    rng = np.random.default_rng(seed)
    a = positive_definite(n, condition, rng)
    b = rng.standard_normal((n, 2))
    augmented = np.hstack([a + np.tril(rng.standard_normal((n, n)), -1), b])  # upper triangle read
    eliminated = augmented.copy()
    assert ldl_eliminate(eliminated, n, n + 2)
    # The factor: d_j = 1 / diagonal, L[i, j] = a[j, i] / d_j above the diagonal; L D L^T = A to n eps |A|.
    d = 1.0 / np.diag(eliminated)[:n]
    unit_lower = np.eye(n) + np.triu(eliminated[:, :n], 1).T / d
    assert np.linalg.norm(unit_lower @ np.diag(d) @ unit_lower.T - a, 2) <= bound(n) * np.linalg.norm(a, 2)
    # The carried right-hand sides hold L^-1 B.
    reference = scipy.linalg.solve_triangular(unit_lower, b, lower=True, unit_diagonal=True)
    error = np.linalg.norm(eliminated[:, n:] - reference)
    assert error <= bound(n, np.linalg.cond(unit_lower)) * np.linalg.norm(reference)
    reference = scipy.linalg.solve(a, b, assume_a="pos")
    substituted = np.empty(n)
    ldl_back_substitute(eliminated, n, n, substituted)  # the first right-hand side, solved
    assert np.linalg.norm(substituted - reference[:, 0]) <= bound(n, condition) * np.linalg.norm(reference[:, 0])
    symmetric_solve(augmented, n)
    assert np.linalg.norm(augmented[:, n:] - reference) <= bound(n, condition) * np.linalg.norm(reference)


@pytest.mark.parametrize("n, seed", [(n, seed) for n in SIZES for seed in range(3)])
def test_ldl_elimination_flags_an_indefinite_matrix(n, seed):
    """Without pivoting the pivots have the inertia of the matrix (Sylvester): one is not positive, and the
    elimination returns False, also for a leading block of a larger array."""
    a = np.zeros((n + 2, n + 4))
    a[:n, :n] = indefinite(n, 1e4, np.random.default_rng(seed))
    assert not ldl_eliminate(a, n, n + 4)


def test_ldl_elimination_flags_a_singular_or_non_finite_pivot():
    assert not ldl_eliminate(np.zeros((3, 3)), 3, 3)
    a = np.eye(3)
    a[1, 1] = np.inf
    assert not ldl_eliminate(a, 3, 3)


@pytest.mark.parametrize("n, condition, seed", cases())
@pytest.mark.parametrize("kind", ["positive definite", "indefinite"])
def test_jacobi_eigen_solve_matches_lapack(n, condition, seed, kind):
    """Eigenvalues ascending, each within n eps |A| of LAPACK's (Weyl: eigenvalues are perfectly conditioned
    in absolute terms), eigenvectors orthonormal and with residuals |A v - lambda v| of n eps |A|."""
    rng = np.random.default_rng(seed)
    a = (positive_definite if kind == "positive definite" else indefinite)(n, condition, rng)
    values, vectors = symmetric_eigen(a)
    reference = scipy.linalg.eigh(a, eigvals_only=True)
    norm = np.linalg.norm(a, 2)
    assert np.all(np.diff(values) >= 0.0)
    assert np.abs(values - reference).max() <= bound(n) * norm
    assert np.abs(vectors.T @ vectors - np.eye(n)).max() <= bound(n)
    assert np.linalg.norm(a @ vectors - vectors * values, 2) <= bound(n) * norm


@pytest.mark.parametrize("n, condition, seed", cases())
@pytest.mark.parametrize("kind", ["positive definite", "indefinite", "unsymmetric"])
def test_pivoted_elimination_matches_lapack(n, condition, seed, kind):
    rng = np.random.default_rng(seed)
    if kind == "unsymmetric":  # U diag(s) V^T with prescribed singular values
        u, _ = np.linalg.qr(rng.standard_normal((n, n)))
        v, _ = np.linalg.qr(rng.standard_normal((n, n)))
        a = (u * np.geomspace(1.0 / condition, 1.0, n)) @ v.T
    else:
        a = (positive_definite if kind == "positive definite" else indefinite)(n, condition, rng)
    b = rng.standard_normal(n)
    padded, right = np.zeros((n + 1, n + 1)), np.zeros(n + 1)  # the leading block only
    padded[:n, :n], right[:n] = a, b
    assert not solve_dense(padded, right, n)
    reference = scipy.linalg.solve(a, b)
    assert np.linalg.norm(right[:n] - reference) <= bound(n, condition) * np.linalg.norm(reference)
    assert np.linalg.norm(a @ right[:n] - b) <= bound(n) * np.linalg.norm(a, 2) * np.linalg.norm(reference)


def test_pivoted_elimination_flags_an_exactly_singular_matrix():
    """Only an exactly zero pivot counts as singular: a zero column, or a rank-deficient matrix whose
    elimination cancels exactly (integer entries)."""
    a = np.random.default_rng(0).standard_normal((4, 4))
    a[:, 2] = 0.0
    assert solve_dense(a, np.ones(4), 4)
    rank_two = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [1.0, 1.0, 1.0]])
    assert solve_dense(rank_two, np.ones(3), 3)


@pytest.mark.parametrize("condition", CONDITIONS)
def test_back_substitution_of_an_upper_triangle(condition):
    rng = np.random.default_rng(1)
    n = 10
    upper = np.triu(rng.standard_normal((n, n)), 1) + np.diag(np.geomspace(1.0, condition, n))
    b = rng.standard_normal(n + 1)
    x = b.copy()
    back_substitute(upper, x, n)
    reference = scipy.linalg.solve_triangular(upper, b[:n], lower=False)
    assert np.linalg.norm(x[:n] - reference) <= bound(n, np.linalg.cond(upper)) * np.linalg.norm(reference)
    assert x[n] == b[n]


def test_products_match_numpy():
    """dot, a x and a^T x (the last four rows at a time, with a remainder) to n eps of the magnitudes summed."""
    rng = np.random.default_rng(2)
    for rows, columns in ((15, 6), (41, 120), (3, 7)):
        a, x, y = rng.standard_normal((rows, columns)), rng.standard_normal(columns), rng.standard_normal(rows)
        scale_matvec = np.abs(a) @ np.abs(x)
        scale_rmatvec = np.abs(a).T @ np.abs(y)
        assert np.all(np.abs(matvec(a, x, np.empty(rows)) - a @ x) <= bound(columns) * scale_matvec)
        assert np.all(np.abs(rmatvec(a, y, np.full(columns, np.nan)) - a.T @ y) <= bound(rows) * scale_rmatvec)
        assert abs(dot(x, x) - x @ x) <= bound(columns) * (x @ x)
