"""Linear springs joining the lap through whole-joint patches (paper 4.1; docs/design.md sections 4 and 5).

Each of the five interface patches of each half is averaged to a 6-DOF virtual node (``fem.coupling``: the
area-weighted least-squares rigid motion u_v = (t, theta) = T u, nodal areas of the six-node triangles). Patch
pair p is joined by springs k_p = (k_x, k_y, k_z, k_rx, k_ry, k_rz) (N/m, N m/rad) on the relative motion
r_p = u_v,upper,p - u_v,lower,p, so the joint adds

    K_joint = (T_upper - T_lower)^T diag(k) (T_upper - T_lower)      (n_dof, n_dof), N/m

to the stiffness of the two otherwise free halves. Every patch centroid lies on the lap axis (y = 0, z = 0), so
translational springs alone leave the relative twist of the halves about x free: a seventh zero-frequency mode,
which rotational springs (or the bolts) remove.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import MeshTet

from geometry.beam_mesh import BeamMesh

from .bolts import quadratic_triangles
from .coupling import coupling_matrix, nodal_areas
from .elasticity import quadratic_node_coordinates
from .modes import node_dofs

N_PATCHES = 5


def patch_couplings(mesh: MeshTet, beam_mesh: BeamMesh) -> tuple[np.ndarray, sp.csr_matrix, sp.csr_matrix]:
    """Virtual nodes of the lower and upper interface patches.

    Returns (reference points (5, 3) m, the lower patches' weighted centroids, which the upper ones share;
    T_lower, T_upper (30, n_dof) CSR): rows 6 (p - 1) .. 6 (p - 1) + 5 are (t, theta) of patch p about its
    centroid.
    """
    coordinates = quadratic_node_coordinates(mesh)
    all_dofs = node_dofs(np.arange(len(coordinates)))

    def couplings(side: str, references: np.ndarray | None):
        node_sets = []
        for patch in range(1, N_PATCHES + 1):
            weights = nodal_areas(coordinates, quadratic_triangles(mesh, beam_mesh.faces[f"{side}_patch_{patch}"]))
            nodes = np.flatnonzero(weights)
            node_sets.append((nodes, weights[nodes]))
        return coupling_matrix(coordinates, node_sets, all_dofs, 3 * len(coordinates), references,
                               [f"{side}_patch_{patch}" for patch in range(1, N_PATCHES + 1)])

    references, lower = couplings("lower", None)
    _, upper = couplings("upper", references)
    return references, lower, upper


def joint_stiffness(lower: sp.csr_matrix, upper: sp.csr_matrix, springs: np.ndarray) -> sp.csr_matrix:
    """K_joint = D^T diag(k) D with D = T_upper - T_lower, (n_dof, n_dof) N/m.

    lower, upper: (6 n_patches, n_dof) patch couplings (``patch_couplings``); springs: (6,) for every patch pair or
    (n_patches, 6), (k_x, k_y, k_z) N/m and (k_rx, k_ry, k_rz) N m/rad.
    """
    relative = (upper - lower).tocsr()
    stiffness = np.broadcast_to(np.asarray(springs, dtype=float), (lower.shape[0] // 6, 6)).ravel()
    return (relative.T @ sp.diags(stiffness) @ relative).tocsr()
