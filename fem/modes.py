"""Linear modes of the two-half beams with the lap interface tied (docs/design.md section 3).

Tying identifies every upper interface quadratic node (vertex or edge midpoint) with its lower partner at the
same position: u = T q, where T keeps every DOF except the tied upper ones, whose rows copy their lower
partner's column. The tied problem T^T K T q = omega^2 T^T M T q has no penalty and no multipliers; its
frequencies are the upper bound of the low-amplitude frequencies of the jointed beam.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import MeshTet

from .elasticity import edge_indices
from .solver import natural_modes


def interface_quadratic_pairs(mesh: MeshTet, lower_vertices: np.ndarray,
                              upper_vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Extend interface vertex pairs to all quadratic interface nodes (vertices and edge midpoints).

    lower_vertices, upper_vertices: (n_pairs,) partner vertex indices (``geometry.beam_mesh.interface_partners``).
    An edge whose two ends are lower interface vertices lies in the interface plane; its partner is the upper
    edge joining the two partner vertices. Returns (lower, upper) quadratic node indices (vertices, then
    n_vertices + edge index), equal length. Raises ValueError when an interface edge has no upper partner.
    """
    n_vertices = mesh.p.shape[1]
    partner = np.full(n_vertices, -1, dtype=np.int64)
    partner[lower_vertices] = upper_vertices
    lower_edges = np.flatnonzero((partner[mesh.edges[0]] >= 0) & (partner[mesh.edges[1]] >= 0))
    upper_edges = edge_indices(mesh, partner[mesh.edges[0, lower_edges]], partner[mesh.edges[1, lower_edges]])
    if np.any(upper_edges < 0):
        raise ValueError("interface not conforming: a lower interface edge has no upper partner edge")
    return (np.concatenate([lower_vertices, n_vertices + lower_edges]),
            np.concatenate([upper_vertices, n_vertices + upper_edges]))


def node_dofs(nodes: np.ndarray) -> np.ndarray:
    """DOFs (n_nodes, 3) of quadratic nodes: 3 p + k for components k = x, y, z."""
    return 3 * np.asarray(nodes)[:, None] + np.arange(3)


def identification(n_dof: int, master_dofs: np.ndarray, slave_dofs: np.ndarray) -> sp.csr_matrix:
    """The map u = T q that makes each slave DOF equal to its master DOF, (n_dof, n_dof - n_slaves), entries 0/1.

    master_dofs, slave_dofs: (n,) DOF indices, disjoint; q holds the kept DOFs in increasing order.
    """
    kept = np.ones(n_dof, dtype=bool)
    kept[slave_dofs] = False
    column = np.full(n_dof, -1, dtype=np.int64)
    column[kept] = np.arange(kept.sum())
    column[slave_dofs] = column[master_dofs]
    return sp.csr_matrix((np.ones(n_dof), (np.arange(n_dof), column)), shape=(n_dof, int(kept.sum())))


def tie_transformation(n_dof: int, lower_nodes: np.ndarray, upper_nodes: np.ndarray) -> sp.csr_matrix:
    """The tie u = T q: each upper node's three displacements equal its lower partner's (``identification``)."""
    return identification(n_dof, node_dofs(lower_nodes).ravel(), node_dofs(upper_nodes).ravel())


def tied_modes(stiffness: sp.spmatrix, mass: sp.spmatrix, tie: sp.spmatrix, n_modes: int,
               method: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Lowest free-free modes with the interface tied.

    stiffness, mass: (n_dof, n_dof) of the two halves; tie: (n_dof, n_tied) from ``tie_transformation``.
    Returns (frequencies (n_modes,) Hz including the six rigid-body modes, shapes (n_dof, n_modes) mass-normalised).
    """
    frequencies, shapes = natural_modes((tie.T @ stiffness @ tie).tocsr(), (tie.T @ mass @ tie).tocsr(),
                                        n_modes, method=method)
    return frequencies, tie @ shapes
