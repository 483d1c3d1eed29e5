"""Frictionless hard contact between the interface node pairs: the bolt-preload static solve (docs/design.md section 3).

For each interface pair i (lower node l, upper node s at the same position, normal +z) the gap is
g_i = u_z(s) - u_z(l) and the contact force on the upper node is N_i (+z). Conditions: g >= 0, N >= 0, g N = 0.

Primal-dual active set (a semismooth Newton method for this complementarity problem): on the active set the
pair's gap is held at zero (exact, no penalty); the linear problem is solved; a pair
leaves the set when its force is tensile and enters it when it penetrates; repeat until the set is unchanged,
which is then the exact solution of the complementarity problem for this discretisation.

The structure is free-free and the bolt loads are self-equilibrated. Rigid-body motion is removed by a
statically determinate (3-2-1) support on the lower half: six constrained DOFs at three vertices, which carry
no reaction when the loads are in equilibrium (checked by the caller through the returned reactions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .solver import pattern_factorizer

CG_CHANGES = 10  # at most this many pairs changed: conjugate gradients preconditioned by the last factorisation
CG_TOLERANCE = 1e-13  # their relative residual


@dataclass(frozen=True)
class ContactSolution:
    """Result of the preload solve.

    displacement: (n_dof,) m; normal_force: (n_pairs,) N, contact force on each upper interface node (+z,
    compressive >= 0); gap: (n_pairs,) m; active: (n_pairs,) bool, pairs in contact; reactions: (6,) N at the
    support DOFs; iterations: active-set iterations.
    """

    displacement: np.ndarray
    normal_force: np.ndarray
    gap: np.ndarray
    active: np.ndarray
    reactions: np.ndarray
    iterations: int


def support_321(coordinates: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Six DOFs of a statically determinate support on a body given by its vertices (k,) (indices into coordinates).

    A: the vertex nearest the (min x, min y, min z) corner, all three translations; B: nearest (max x, min y,
    min z), y and z; C: nearest (min x, max y, min z), z. Returns DOF indices (6,).
    """
    box = coordinates[vertices]
    low, high = box.min(axis=0), box.max(axis=0)

    def nearest(target):
        return vertices[np.argmin(np.linalg.norm(box - target, axis=1))]

    a, b, c = nearest(low), nearest([high[0], low[1], low[2]]), nearest([low[0], high[1], low[2]])
    return np.array([3 * a, 3 * a + 1, 3 * a + 2, 3 * b + 1, 3 * b + 2, 3 * c + 2])


def gap_coordinates(n_dof: int, lower_z: np.ndarray, upper_z: np.ndarray) -> sp.csr_matrix:
    """The change of variables u = T v, (n_dof, n_dof): v equals u except at each upper interface z DOF, where it
    holds the pair's gap g = u_z(upper) - u_z(lower). lower_z, upper_z: (n_pairs,) partner z DOFs."""
    rows = np.concatenate([np.arange(n_dof), upper_z])
    columns = np.concatenate([np.arange(n_dof), lower_z])
    return sp.csr_matrix((np.ones(len(rows)), (rows, columns)), shape=(n_dof, n_dof))


def pinned(matrix: sp.csr_matrix, held: np.ndarray) -> sp.csr_matrix:
    """``matrix`` (n, n) with the rows and columns of the held DOFs (n,) bool replaced by its diagonal there
    (those unknowns are zero for a zero right-hand side), keeping the sparsity pattern, explicit zeros included,
    so that one symbolic factorisation serves every set of held DOFs. matrix: canonical CSR."""
    rows = np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))
    free = ~held
    result = matrix.copy()
    result.data *= free[rows] & free[matrix.indices]
    on_diagonal = np.flatnonzero((rows == matrix.indices) & held[rows])
    result.data[on_diagonal] = matrix.data[on_diagonal]
    return result


def frictionless_contact(stiffness: sp.spmatrix, forces: np.ndarray, lower_nodes: np.ndarray,
                         upper_nodes: np.ndarray, supported: np.ndarray, max_iterations: int = 50,
                         method: str | None = None) -> ContactSolution:
    """Solve K u = f + contact forces with frictionless node-to-node contact (primal-dual active set).

    stiffness: (n_dof, n_dof) N/m, the two halves and the bolts (the only links between them besides contact);
    forces: (n_dof,) N, self-equilibrated; lower_nodes, upper_nodes: (n_pairs,) partner quadratic nodes;
    supported: (6,) DOFs held at zero (``support_321``); method: factorisation (``fem.solver.factorize``).
    Starts with every pair in contact.

    In the gap coordinates v (``gap_coordinates``) a closed pair and a support hold one unknown at zero, so
    every active set gives a matrix of one sparsity pattern (``pinned``): it is analysed once and refactorised
    numerically. When only a few pairs change (the last iterations), the new system is solved by conjugate
    gradients preconditioned by the last factorisation instead (a rank-k change: about 2k iterations), to the
    relative residual ``CG_TOLERANCE``; a refactorisation follows if they do not converge.
    Raises RuntimeError when the active set has not settled after ``max_iterations``, with the number of pairs
    that still change and the largest penetration or tension.
    """
    n_dof = stiffness.shape[0]
    lower_z, upper_z = 3 * np.asarray(lower_nodes) + 2, 3 * np.asarray(upper_nodes) + 2
    to_gaps = gap_coordinates(n_dof, lower_z, upper_z)
    system = (to_gaps.T @ stiffness @ to_gaps).tocsr()
    system.sum_duplicates()
    load = to_gaps.T @ forces
    factorizer = pattern_factorizer(system, method)
    active = np.ones(len(lower_z), dtype=bool)
    preconditioner, unknowns, changed = None, np.zeros(n_dof), len(active)
    for iteration in range(1, max_iterations + 1):
        held = np.zeros(n_dof, dtype=bool)
        held[supported] = True
        held[upper_z[active]] = True
        matrix, right_hand_side = pinned(system, held), np.where(held, 0.0, load)
        solved = False
        if preconditioner is not None and changed <= CG_CHANGES:
            unknowns, info = spla.cg(matrix, right_hand_side, x0=unknowns, rtol=CG_TOLERANCE,
                                     maxiter=2 * changed + 10, M=spla.LinearOperator(matrix.shape, preconditioner))
            solved, unknowns[held] = info == 0, 0.0
        if not solved:
            preconditioner = None  # release the last factor before the next one is formed (peak memory)
            preconditioner = factorizer(matrix)
            unknowns = preconditioner(right_hand_side)
        displacement = to_gaps @ unknowns
        residual = stiffness @ displacement - forces
        normal_force, gap = residual[upper_z], displacement[upper_z] - displacement[lower_z]
        updated = np.where(active, normal_force >= 0, gap < 0)
        changed = int(np.sum(updated != active))
        if changed == 0:
            return ContactSolution(displacement, np.where(active, normal_force, 0.0), gap, active,
                                   residual[supported], iteration)
        active = updated
    raise RuntimeError(f"contact active set not settled after {max_iterations} iterations: {changed} pairs still "
                       f"change, largest penetration {max(-gap.min(), 0.0):.3g} m, largest tension "
                       f"{max(-normal_force[active].min(initial=0.0), 0.0):.3g} N")
