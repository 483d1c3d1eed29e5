"""Sparse direct factorisation and shift-invert eigen-solves of the free-free beams.

The fastest available factorisation of a symmetric positive definite matrix is used: CHOLMOD (scikit-sparse
< 0.5, built against Debian's libsuitesparse-dev) when it imports, otherwise SciPy's SuperLU. Measured here
for 18 free-free modes at 169k DOF: CHOLMOD 11 s, SuperLU 70 s (run with OPENBLAS_NUM_THREADS=1: numpy's and
CHOLMOD's BLAS threads otherwise compete for the cores).

A free-free structure has a singular K; the shift sigma = -(2 pi f_shift)^2 < 0 makes K - sigma M positive
definite, so the same Cholesky factorisation serves every free-free solve and the six rigid-body modes come out
as the eigenvalues nearest sigma, at numerically zero frequency.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:
    from sksparse.cholmod import analyze as _cholmod_analyze
    from sksparse.cholmod import cholesky as _cholmod_cholesky
except ImportError:  # scikit-sparse absent or built against another SuiteSparse: SuperLU below
    _cholmod_analyze = _cholmod_cholesky = None


def factorization_name() -> str:
    """Which factorisation ``factorize`` uses here: 'cholmod' or 'superlu'."""
    return "cholmod" if _cholmod_cholesky is not None else "superlu"


def factorize(matrix: sp.spmatrix, method: str | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """Factorise a symmetric positive definite sparse matrix (n, n); returns x = solve(b) for b of shape (n,) or (n, k).

    method: 'cholmod' or 'superlu'; default the fastest available (``factorization_name()``).
    """
    method = method or factorization_name()
    if method == "cholmod":
        if _cholmod_cholesky is None:
            raise RuntimeError("CHOLMOD requested but scikit-sparse is not importable")
        return _cholmod_cholesky(sp.csc_matrix(matrix))
    if method == "superlu":
        return spla.splu(sp.csc_matrix(matrix), permc_spec="MMD_AT_PLUS_A").solve
    raise ValueError(f"unknown factorisation '{method}': expected 'cholmod' or 'superlu'")


def pattern_factorizer(pattern: sp.spmatrix, method: str | None = None
                       ) -> Callable[[sp.spmatrix], Callable[[np.ndarray], np.ndarray]]:
    """A factorize function for a sequence of symmetric positive definite matrices that all have the sparsity
    pattern (explicit zeros included) of ``pattern`` (n, n): CHOLMOD orders and analyses the pattern once and
    then only computes the numbers; SuperLU factorises each afresh. Returns matrix -> solve, as ``factorize``.
    """
    method = method or factorization_name()
    if method == "cholmod" and _cholmod_analyze is not None:
        symbolic = _cholmod_analyze(sp.csc_matrix(pattern))
        return lambda matrix: symbolic.cholesky(sp.csc_matrix(matrix))
    return lambda matrix: factorize(matrix, method)


def frequencies_hz(eigenvalues: np.ndarray) -> np.ndarray:
    """Signed natural frequencies sign(lambda) sqrt(|lambda|) / (2 pi), Hz, from eigenvalues lambda = omega^2 (rad^2/s^2)."""
    return np.sign(eigenvalues) * np.sqrt(np.abs(eigenvalues)) / (2 * np.pi)


def natural_modes(stiffness: sp.spmatrix, mass: sp.spmatrix, n_modes: int, shift_hz: float = 10.0,
                  method: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Lowest modes of K phi = omega^2 M phi by shift-invert Lanczos about sigma = -(2 pi shift_hz)^2.

    stiffness, mass: (n, n) symmetric, K positive semidefinite (free-free allowed), M positive definite.
    Returns (frequencies, shapes): frequencies (n_modes,) Hz ascending (signed, see ``frequencies_hz``),
    shapes (n, n_modes) mass-normalised (phi^T M phi = I), signs by ``sign_convention``. The Lanczos start vector
    is fixed, so the same matrices give the same floats run after run (and the FE files the same hashes).
    """
    sigma = -(2 * np.pi * shift_hz) ** 2
    solve = factorize((stiffness - sigma * mass).tocsc(), method)
    inverse = spla.LinearOperator(stiffness.shape, matvec=solve, dtype=float)
    eigenvalues, shapes = spla.eigsh(stiffness, k=n_modes, M=mass, sigma=sigma, OPinv=inverse, which="LM",
                                     v0=np.ones(stiffness.shape[0]))
    order = np.argsort(eigenvalues)
    shapes = shapes[:, order]
    shapes /= np.sqrt(np.einsum("ij,ij->j", shapes, mass @ shapes))
    return frequencies_hz(eigenvalues[order]), sign_convention(shapes)


def sign_convention(shapes: np.ndarray) -> np.ndarray:
    """Mode shapes (n, n_modes) with each column's largest entry positive (reproducible files; a mode's sign is
    arbitrary)."""
    return shapes * np.sign(shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])])
