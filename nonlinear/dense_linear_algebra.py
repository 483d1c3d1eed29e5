"""Small dense linear algebra, compiled (numba): products, Cholesky and LDL^T factorisations, triangular and
pivoted solves, and the symmetric eigenproblem by Jacobi rotations.

Sizes here are those of the joint problems (n up to a few dozen, ``nonlinear.stuck_modes`` and
``nonlinear.qsma_kernel``), where plain loops beat BLAS/LAPACK calls, whose overhead exceeds the work, and let
numba inline the routines into their callers. Every routine works in place on caller-owned arrays (no
allocation per call, except ``symmetric_eigen``), reads the upper triangle of a symmetric matrix, and is
backward stable at the usual size: a residual of order n eps |A|, so a solution error of order
n eps cond(A) (Golub & Van Loan, Matrix Computations, 4th ed.: Cholesky 4.2, LDL^T 4.1, partial pivoting
3.4, cyclic Jacobi 8.5). Positive definiteness and singularity are reported as documented per routine,
never raised (they run inside compiled loops over designs).

Everything compiled here and in its callers is strict IEEE arithmetic, without numba's fast-math flags: with
reassociation or fused multiply-adds, what LLVM makes of a routine depends on whether it is inlined into a caller
compiled in the same process or linked from numba's on-disk cache, and 300 ASB designs differed between a process
that compiled the kernels and one that loaded them (by up to 2e-8 Hz in a backbone frequency, the last bits
amplified on ill-conditioned levels): a study's rows depended on which process compiled first. Strict arithmetic
gives the same bits either way, for about 8 % of the rates (docs/benchmarks.md).
"""

from __future__ import annotations

import math

import numba
import numpy as np

JACOBI_TOLERANCE = 1e-16  # off-diagonal entries below this times the matrix norm are left alone
MAX_JACOBI_SWEEPS = 30


@numba.njit(cache=True)
def dot(x, y):
    """x . y of two vectors (a loop: no temporary array)."""
    total = 0.0
    for i in range(x.size):
        total += x[i] * y[i]
    return total


@numba.njit(cache=True)
def copy_matrix(source, out):
    """out = source for two matrices of one shape, by loops (slice assignment from an array also compiles numba's
    formatted shape-mismatch error: seconds of a cold compile)."""
    rows, columns = source.shape
    for i in range(rows):
        for j in range(columns):
            out[i, j] = source[i, j]
    return out


@numba.njit(cache=True)
def matvec(a, x, out):
    """out = a x for a small dense matrix (plain loops: BLAS calls cost more than the work at these sizes)."""
    rows, columns = a.shape
    for i in range(rows):
        total = 0.0
        for j in range(columns):
            total += a[i, j] * x[j]
        out[i] = total
    return out


@numba.njit(cache=True)
def rmatvec(a, x, out):
    """out = a^T x for a small dense matrix, summed in the order of the rows, four rows of ``a`` per pass over
    ``out`` (a quarter of its loads and stores: the 40 x 120 product of
    ``nonlinear.stuck_modes._high_flexibility`` 1.5 times faster)."""
    rows = a.shape[0]
    out[:] = 0.0
    for i in range(0, rows - 3, 4):
        x0, x1, x2, x3 = x[i], x[i + 1], x[i + 2], x[i + 3]
        a0, a1, a2, a3 = a[i], a[i + 1], a[i + 2], a[i + 3]
        for j in range(out.size):
            out[j] = (((out[j] + a0[j] * x0) + a1[j] * x1) + a2[j] * x2) + a3[j] * x3
    for i in range(rows - rows % 4, rows):
        xi, ai = x[i], a[i]
        for j in range(out.size):
            out[j] += ai[j] * xi
    return out


@numba.njit(cache=True)
def cholesky(a, upper):
    """Cholesky factor of the symmetric positive definite ``a`` (its upper triangle is read) into ``upper``
    (same shape), stored as the upper triangular U = L^T (A = U^T U), row by row with right-looking updates
    along rows (contiguous). No check: a matrix not numerically positive definite gives a NaN factor (the square
    root of a negative pivot is taken as NaN, as compiled code does, also where Python runs it: numba-cuda's
    simulator)."""
    n = a.shape[0]
    for i in range(n):
        for j in range(i):
            upper[i, j] = 0.0
        for j in range(i, n):
            upper[i, j] = a[i, j]
    for j in range(n):
        pivot = upper[j, j]
        inverse = 1.0 / math.sqrt(pivot) if pivot >= 0.0 else math.nan
        for i in range(j, n):
            upper[j, i] *= inverse
        for k in range(j + 1, n):
            factor = upper[j, k]
            for i in range(k, n):
                upper[k, i] -= factor * upper[j, i]
    return upper


@numba.njit(cache=True)
def forward_substitute(upper, b):
    """U^-T b (= L^-1 b) for the factor of ``cholesky`` and b (n, k), in place (all right-hand sides in the
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


@numba.njit(cache=True)
def backward_substitute(upper, b):
    """U^-1 b (= L^-T b) for the factor of ``cholesky`` and b (n, k), in place."""
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


@numba.njit(cache=True, inline="always")
def ldl_eliminate(a, n, width):
    """Symmetric Gaussian elimination (LDL^T: no square roots, which would lengthen the chain of dependent
    operations) of the symmetric positive definite leading n x n block of ``a`` (its upper triangle is read),
    in place, each row carried to column ``width``: a[j, i] = d_j L[i, j] above the diagonal and 1 / d_j on it,
    and columns n to width (right-hand sides B) left holding L^-1 B. The inner loops run over row views from
    index 0, so that the compiler sees non-negative indices (no wrap-around test) and vectorises them: 1.6 to
    2 times as fast as indexing from a row's diagonal at n = 15. Returns False, leaving ``a`` spoiled, where a
    pivot is not positive and finite (the block not numerically positive definite)."""
    for j in range(n):
        pivot = a[j, j]
        if not 0.0 < pivot < np.inf:
            return False
        inverse = 1.0 / pivot
        a[j, j] = inverse
        for k in range(j + 1, n):
            multiplier = a[j, k] * inverse  # L[k, j]
            target, source = a[k, k:width], a[j, k:width]
            for i in range(target.size):
                target[i] -= multiplier * source[i]
    return True


@numba.njit(cache=True, inline="always")
def ldl_back_substitute(factor, n, column, out):
    """The solution x = L^-T D^-1 c of L D L^T x = b into out[:n], from ``ldl_eliminate(factor, n, width)``
    having carried b along in ``column`` (which then holds c = L^-1 b)."""
    for j in range(n - 1, -1, -1):
        total = factor[j, column]
        for i in range(j + 1, n):
            total -= factor[j, i] * out[i]
        out[j] = total * factor[j, j]


@numba.njit(cache=True)
def symmetric_solve(augmented, n):
    """A^-1 B for the symmetric positive definite A in the upper triangle of the leading n x n block of
    ``augmented`` (n, n + k) and the k right-hand sides B in its last k columns, in place (the solution there;
    the block is left holding the eliminated factor): ``ldl_eliminate`` with the right-hand sides carried
    along the contiguous rows, then back substitution column by column of the factor."""
    ldl_eliminate(augmented, n, augmented.shape[1])
    for j in range(n - 1, -1, -1):
        solution = augmented[j, n:]
        inverse = augmented[j, j]
        for c in range(solution.size):
            solution[c] *= inverse
        for k in range(j):
            multiplier = augmented[k, j]
            target = augmented[k, n:]
            for c in range(target.size):
                target[c] -= multiplier * solution[c]


@numba.njit(cache=True)
def symmetric_eigen_in_place(a, values, vectors):
    """Eigenvalues (ascending, into ``values``) and orthonormal eigenvectors (columns, into ``vectors``) of a
    small symmetric matrix ``a`` (overwritten) by cyclic Jacobi rotations, until every off-diagonal entry is
    below JACOBI_TOLERANCE times the matrix norm (backward error of order eps times the norm)."""
    n = a.shape[0]
    squares = 0.0
    for i in range(n):
        for j in range(n):
            squares += a[i, j] * a[i, j]
            vectors[i, j] = 1.0 if i == j else 0.0
    threshold = JACOBI_TOLERANCE * math.sqrt(squares)
    for _ in range(MAX_JACOBI_SWEEPS):
        rotated = False
        for p in range(n - 1):
            for q in range(n):  # q > p, counted from 0: the compiler sees non-negative indices
                if q <= p or abs(a[p, q]) <= threshold:
                    continue
                rotated = True
                angle = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
                tangent = (1.0 if angle >= 0.0 else -1.0) / (abs(angle) + math.sqrt(angle * angle + 1.0))
                cosine = 1.0 / math.sqrt(tangent * tangent + 1.0)
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
    for i in range(n):
        values[i] = a[i, i]
    for i in range(n):  # selection sort, swapping the eigenvectors along
        smallest = i
        for j in range(i + 1, n):
            if values[j] < values[smallest]:
                smallest = j
        if smallest != i:
            values[i], values[smallest] = values[smallest], values[i]
            for k in range(n):
                vectors[k, i], vectors[k, smallest] = vectors[k, smallest], vectors[k, i]


@numba.njit(cache=True)
def symmetric_eigen(a):
    """Eigenvalues (ascending) and orthonormal eigenvectors (columns) of a small symmetric matrix
    (``symmetric_eigen_in_place`` on a copy)."""
    n = a.shape[0]
    values, vectors = np.empty(n), np.empty((n, n))
    symmetric_eigen_in_place(a.copy(), values, vectors)
    return values, vectors


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def back_substitute(upper, b, n):
    """Solve the leading n x n upper-triangular block of ``upper`` against b[:n], in place in b."""
    for k in range(n - 1, -1, -1):
        total = b[k]
        for j in range(k + 1, n):
            total -= upper[k, j] * b[j]
        b[k] = total / upper[k, k]
