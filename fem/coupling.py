"""Distributing (RBE3-like) couplings: a set of surface nodes averaged to one 6-DOF reference node.

Used for the bolts' washer footprints (fem/bolts.py) and for the whole-joint interface patches, each averaged
to a virtual node (paper 4.1, reduction stage). The reference node carries u_v = (t, theta), the weighted
least-squares rigid motion of the nodes, written about their weighted centroid c (docs/design.md section 4):

    minimise  sum_i w_i |u_i - t - theta x r_i|^2,   r_i = x_i - c,   c = sum_i w_i x_i / W,   W = sum_i w_i.

Because sum_i w_i r_i = 0 the translation and rotation decouple:

    t = sum_i w_i u_i / W,     J theta = sum_i w_i r_i x u_i,     J = sum_i w_i (|r_i|^2 I - r_i r_i^T),

so u_v = T u_nodes with T (6, 3n) built explicitly below; about another reference point a the translation is
t_a = t + theta x (a - c). The average does not stiffen the nodes. By virtual work the generalised force on the
reference node conjugate to u_v, for nodal forces f_i on nodes that move rigidly with it, is the resultant force
and the moment about the reference point.

The weights are the nodal areas of the face (the consistent load vector of a unit traction), so a uniform
traction p maps to the force p A and no moment about c.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class CouplingError(ValueError):
    """A node set cannot define a rigid motion (too few nodes, or all on one line)."""


def nodal_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Consistent nodal areas of a triangulated face, m^2, shape (n_points,) (zero off the face).

    triangles: (m, 3) linear or (m, 6) quadratic (corners first, then mid-sides) node indices. A unit traction
    gives nodal forces equal to these areas: A/3 at each corner of a linear triangle; 0 at the corners and A/3
    at the mid-sides of a straight-sided quadratic one. They sum to the face area.
    """
    a, b, c = (points[triangles[:, i]] for i in range(3))
    area = np.linalg.norm(np.cross(b - a, c - a), axis=1) / 2
    share = {3: np.full(3, 1 / 3), 6: np.array([0, 0, 0, 1 / 3, 1 / 3, 1 / 3])}[triangles.shape[1]]
    weights = np.zeros(len(points))
    np.add.at(weights, triangles, area[:, None] * share)
    return weights


def _cross_matrices(r: np.ndarray) -> np.ndarray:
    """[r]_x for each row of r (n, 3): matrices (n, 3, 3) with [r]_x u = r x u."""
    zero = np.zeros(len(r))
    return np.stack([np.stack([zero, -r[:, 2], r[:, 1]], axis=1),
                     np.stack([r[:, 2], zero, -r[:, 0]], axis=1),
                     np.stack([-r[:, 1], r[:, 0], zero], axis=1)], axis=1)


def rigid_average(points: np.ndarray, weights: np.ndarray, reference: np.ndarray | None = None,
                  name: str = "node set") -> tuple[np.ndarray, np.ndarray]:
    """Weighted least-squares rigid motion of a set of nodes.

    points: (n, 3) node positions, m; weights: (n,) non-negative nodal weights (nodes of zero weight are
    allowed and ignored); reference: (3,) point the translation refers to, m (default the weighted centroid).
    Returns the reference point (3,) and T (6, 3n), with node displacements ordered (u1x, u1y, u1z, u2x, ...),
    such that (t, theta) = T u. Raises CouplingError when the weighted nodes do not define a rigid motion
    (fewer than three, or all on one line).
    """
    weights = np.asarray(weights, dtype=float)
    active = weights > 0
    total = weights.sum()
    if active.sum() < 3:
        raise CouplingError(f"{name}: {active.sum()} weighted node(s); a rigid motion needs at least 3 not on a line")
    centroid = weights @ points / total
    r = points - centroid
    inertia = np.einsum("i,ij->", weights, r * r) * np.eye(3) - np.einsum("i,ij,ik->jk", weights, r, r)
    eigenvalues = np.linalg.eigvalsh(inertia)
    if eigenvalues[0] <= 1e-10 * eigenvalues[-1]:
        raise CouplingError(f"{name}: weighted nodes lie on one line; their rotation about it is undefined")
    translation = np.kron(weights / total, np.eye(3))
    rotation = np.linalg.solve(inertia, (weights[:, None, None] * _cross_matrices(r)).transpose(1, 0, 2)
                               .reshape(3, -1))
    if reference is None:
        return centroid, np.vstack([translation, rotation])
    arm = np.asarray(reference, dtype=float) - centroid  # t_a = t + theta x arm = t - [arm]_x theta
    return np.asarray(reference, dtype=float), np.vstack([translation - _cross_matrices(arm[None])[0] @ rotation,
                                                          rotation])


def coupling_matrix(points: np.ndarray, node_sets: list[tuple[np.ndarray, np.ndarray]], nodal_dofs: np.ndarray,
                    n_dofs: int, references: np.ndarray | None = None, names: list[str] | None = None):
    """Sparse map from the full displacement vector to the reference-node DOFs of several node sets.

    points: (n_nodes, 3), m; node_sets: for each set (node indices (k,), weights (k,)); nodal_dofs: (n_nodes, 3)
    global DOF index of each node's x, y, z displacement; n_dofs: length of the full vector; references:
    (n_sets, 3) reference points, m (default each set's weighted centroid).
    Returns (reference points (n_sets, 3) m, T as a CSR matrix (6 n_sets, n_dofs)): rows 6p..6p+5 are
    (t_x, t_y, t_z, theta_x, theta_y, theta_z) of set p.
    """
    names = names or [f"node set {p + 1}" for p in range(len(node_sets))]
    references = [None] * len(node_sets) if references is None else references
    rows, columns, values, reference_points = [], [], [], []
    for p, ((nodes, weights), reference, name) in enumerate(zip(node_sets, references, names)):
        point, block = rigid_average(points[nodes], weights, reference, name)
        reference_points.append(point)
        dofs = nodal_dofs[nodes].ravel()
        rows.append(np.repeat(6 * p + np.arange(6), len(dofs)))
        columns.append(np.tile(dofs, 6))
        values.append(block.ravel())
    matrix = sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(columns))),
                           shape=(6 * len(node_sets), n_dofs))
    matrix.eliminate_zeros()
    return np.array(reference_points), matrix
