"""Frictionless hard contact between the interface node pairs: the bolt-preload static solve (DESIGN section 3).

For each interface pair i (lower node l, upper node s at the same position, normal +z) the gap is
g_i = u_z(s) - u_z(l) and the contact force on the upper node is N_i (+z). Conditions: g >= 0, N >= 0, g N = 0.

Primal-dual active set (a semismooth Newton method for this complementarity problem): on the active set the
pair's normal displacements are identified (g = 0, exact, no penalty); the linear problem is solved; a pair
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

from .modes import identification
from .solver import factorize


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


def frictionless_contact(stiffness: sp.spmatrix, forces: np.ndarray, lower_nodes: np.ndarray,
                         upper_nodes: np.ndarray, supported: np.ndarray, max_iterations: int = 50
                         ) -> ContactSolution:
    """Solve K u = f + contact forces with frictionless node-to-node contact (primal-dual active set).

    stiffness: (n_dof, n_dof) N/m, the two halves and the bolts (the only links between them besides contact);
    forces: (n_dof,) N, self-equilibrated; lower_nodes, upper_nodes: (n_pairs,) partner quadratic nodes;
    supported: (6,) DOFs held at zero (``support_321``). Starts with every pair in contact.
    Raises RuntimeError when the active set has not settled after ``max_iterations``.
    """
    n_dof = stiffness.shape[0]
    lower_z, upper_z = 3 * np.asarray(lower_nodes) + 2, 3 * np.asarray(upper_nodes) + 2
    active = np.ones(len(lower_z), dtype=bool)
    for iteration in range(1, max_iterations + 1):
        transformation = identification(n_dof, lower_z[active], upper_z[active])
        kept = np.ones(transformation.shape[1], dtype=bool)
        kept[transformation[supported].indices] = False
        transformation = transformation[:, np.flatnonzero(kept)].tocsc()
        reduced = (transformation.T @ stiffness @ transformation).tocsc()
        displacement = transformation @ factorize(reduced)(transformation.T @ forces)
        residual = stiffness @ displacement - forces
        normal_force, gap = residual[upper_z], displacement[upper_z] - displacement[lower_z]
        updated = np.where(active, normal_force >= 0, gap < 0)
        if np.array_equal(updated, active):
            return ContactSolution(displacement, np.where(active, normal_force, 0.0), gap, active,
                                   residual[supported], iteration)
        active = updated
    raise RuntimeError(f"contact active set not settled after {max_iterations} iterations")
