"""Linear elasticity of the beam meshes: stiffness K and consistent mass M with quadratic tetrahedra.

The geometry stage writes 4-node tetrahedra (or gmsh 10-node ones with straight sides); here only their corners
are used and scikit-fem's quadratic Lagrange tetrahedron (``ElementTetP2``, mid-side nodes at the straight
edge midpoints) is built on them, three displacement components per node (docs/design.md section 3).

Degrees of freedom follow scikit-fem's vector numbering: the "quadratic nodes" are the mesh vertices
(0..n_vertices-1) followed by the edge midpoints (in ``mesh.edges`` order), and the DOF of component k
(0: x, 1: y, 2: z) at quadratic node p is 3 p + k.

Matrices are assembled from scalar forms on the quadratic nodes (the 3 x 3 blocks of elasticity, or one
block times the identity for the mass and the stress stiffness): 2.4 (K) and 6 (M) times faster than
scikit-fem's vector forms on the default BRB, and over element chunks so that the quadrature-point arrays of one chunk, not of the whole mesh,
are held in memory at a time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, CellBasis, ElementTetP2, MeshTet
from skfem.models.elasticity import lame_parameters

CHUNK_ELEMENTS = 20000


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material: Young's modulus Pa, Poisson's ratio, density kg/m^3.

    Validated against the range of structural solids (rubber to diamond): E in [1e6, 1e13] Pa, nu in [0, 0.5),
    density in [1, 1e5] kg/m^3; a value outside (190 typed for 190e9 Pa, nu = 0.5) is refused naming the field,
    before an eigensolver spins on a model whose modes all sit near 0 Hz.
    """

    youngs_modulus: float = 190e9
    poissons_ratio: float = 0.29
    density: float = 7800.0

    def __post_init__(self):
        for field, low, high, unit in (("youngs_modulus", 1e6, 1e13, "Pa"), ("density", 1.0, 1e5, "kg/m^3")):
            value = getattr(self, field)
            if not low <= value <= high:
                raise ValueError(f"field '{field}' = {value!r}: expected {low:g} to {high:g} {unit}")
        if not 0.0 <= self.poissons_ratio < 0.5:
            raise ValueError(f"field 'poissons_ratio' = {self.poissons_ratio!r}: expected 0 <= nu < 0.5")


#: The material of the public BRB ABAQUS input deck (docs/design.md section 3); the default is ``Material()``.
DECK_MATERIAL = Material(youngs_modulus=192.85e9, poissons_ratio=0.29, density=7857.8)


def solid_mesh(points: np.ndarray, tetrahedra: np.ndarray) -> MeshTet:
    """The straight-sided tetrahedral mesh of the solid from node coordinates (n, 3) m and tetrahedra (m, >=4).

    Only the four corner columns of ``tetrahedra`` are used (gmsh order: corners first), so a 10-node input gives
    the same mesh as its 4-node corners. Node indices are kept: vertex i of the result is ``points[i]``.
    """
    return MeshTet(np.ascontiguousarray(points.T, dtype=float),
                   np.ascontiguousarray(tetrahedra[:, :4].T, dtype=np.int64))


def quadratic_node_coordinates(mesh: MeshTet) -> np.ndarray:
    """Coordinates of the quadratic nodes (vertices, then edge midpoints), (n_vertices + n_edges, 3), m."""
    midpoints = 0.5 * (mesh.p[:, mesh.edges[0]] + mesh.p[:, mesh.edges[1]])
    return np.hstack([mesh.p, midpoints]).T


def edge_indices(mesh: MeshTet, first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Indices into ``mesh.edges`` of the edges joining vertices first[i] and second[i] (either order); -1 where
    the mesh has no such edge. Shapes: first, second (n,) -> (n,)."""
    n_vertices = mesh.p.shape[1]
    edges = np.sort(mesh.edges, axis=0)
    keys = edges[0] * n_vertices + edges[1]
    order = np.argsort(keys)
    wanted = np.minimum(first, second) * n_vertices + np.maximum(first, second)
    found = order[np.searchsorted(keys, wanted, sorter=order).clip(max=len(keys) - 1)]
    return np.where(keys[found] == wanted, found, -1)


def node_basis_chunks(mesh: MeshTet, intorder: int) -> Iterator[CellBasis]:
    """The scalar quadratic basis (one function per quadratic node) over successive element chunks.

    intorder: degree of polynomials the tetrahedron quadrature integrates exactly (2: products of gradients of
    straight-sided quadratic elements, 4: products of the shape functions). Global numbering: the quadratic
    node index (vertices, then edges), whatever the chunk. Chunks of ``CHUNK_ELEMENTS`` elements bound the
    memory of the quadrature-point arrays.
    """
    chunk_elements = CHUNK_ELEMENTS
    whole = CellBasis(mesh, ElementTetP2(), elements=np.arange(1), disable_doflocs=True)
    for start in range(0, mesh.t.shape[1], chunk_elements):
        yield CellBasis(mesh, ElementTetP2(), intorder=intorder, dofs=whole.dofs, disable_doflocs=True,
                        elements=np.arange(start, min(start + chunk_elements, mesh.t.shape[1])))


UPPER_BLOCKS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))  # component pairs (a, b), a <= b


def gradient_products(mesh: MeshTet) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element-by-element integrals of products of quadratic shape-function derivatives,
    G_ab[i, j] = integral of d_a phi_i d_b phi_j dV (m), for the component pairs ``UPPER_BLOCKS``.

    Returns rows, columns (n_entries,) quadratic node indices i, j and values (6, n_entries), in scikit-fem's
    element-wise (COO) layout: one entry per element sharing the pair, not yet summed. Degree-2 quadrature is
    exact on straight-sided elements.
    """
    rows, columns, values = [], [], []
    for basis in node_basis_chunks(mesh, intorder=2):
        products = [BilinearForm(lambda u, v, w: v.grad[a] * u.grad[b]).coo_data(basis) for a, b in UPPER_BLOCKS]
        rows.append(products[0].indices[0])
        columns.append(products[0].indices[1])
        values.append(np.stack([product.data for product in products]))
    return np.concatenate(rows), np.concatenate(columns), np.concatenate(values, axis=-1)


def summed_blocks(n_nodes: int, rows: np.ndarray, columns: np.ndarray, upper: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Sum element-wise entries into node pairs and complete the 3 x 3 blocks of a form whose transpose swaps
    the components, G_ba[i, j] = G_ab[j, i].

    rows, columns (n_entries,) quadratic nodes; upper (6, n_entries) the ``UPPER_BLOCKS`` values. Returns the
    node pairs (n_pairs,) as keys i n_nodes + j, ascending, and blocks (3, 3, n_pairs).
    """
    pairs, entry = np.unique(rows.astype(np.int64) * n_nodes + columns, return_inverse=True)
    transposed = np.searchsorted(pairs, (pairs % n_nodes) * n_nodes + pairs // n_nodes)
    blocks = np.empty((3, 3, len(pairs)))
    for (a, b), values in zip(UPPER_BLOCKS, upper):
        blocks[a, b] = np.bincount(entry, weights=values, minlength=len(pairs))
        blocks[b, a] = blocks[a, b][transposed]
    return pairs, blocks


def vector_matrix(n_nodes: int, pairs: np.ndarray, blocks: np.ndarray) -> sp.csr_matrix:
    """The (3 n_nodes, 3 n_nodes) CSR matrix A[3 i + a, 3 j + b] = blocks[a, b, k] for pairs[k] = i n_nodes + j
    (ascending), through 3 x 3 block rows (BSR)."""
    row_starts = np.searchsorted(pairs // n_nodes, np.arange(n_nodes + 1))
    return sp.bsr_matrix((np.moveaxis(blocks, -1, 0), pairs % n_nodes, row_starts),
                         shape=(3 * n_nodes, 3 * n_nodes)).tocsr()


def assemble_isotropic(mesh: MeshTet, form: BilinearForm, intorder: int,
                       fields: Callable[[CellBasis], dict] | None = None) -> sp.csr_matrix:
    """A vector form that acts alike on each displacement component, A = S (x) I_3 in scikit-fem's vector DOF
    numbering, from its scalar form S over the quadratic nodes (mass, stress stiffness).

    intorder: quadrature degree (``node_basis_chunks``); fields: optional function of a chunk's basis
    returning the keyword fields the form reads from ``w``. Returns (3 n_nodes, 3 n_nodes) CSR.
    """
    scalar = sum(form.assemble(basis, **(fields(basis) if fields else {}))
                 for basis in node_basis_chunks(mesh, intorder))
    return sp.kron(scalar, sp.identity(3), format="csr")


def mass_form(material: Material) -> BilinearForm:
    """Consistent mass of one displacement component: integral of rho u v dV, kg."""
    @BilinearForm
    def mass(u, v, w):
        return material.density * u * v
    return mass


def stiffness_matrix(mesh: MeshTet, material: Material) -> sp.csr_matrix:
    """Elastic stiffness K, (n_dof, n_dof), N/m: integral of lambda tr eps(u) tr eps(v) + 2 mu eps(u) : eps(v),
    whose block (a, b) for u = phi_j e_b, v = phi_i e_a is lambda G_ab + mu G_ba + mu delta_ab tr G
    (``gradient_products``)."""
    lame_lambda, shear_modulus = lame_parameters(material.youngs_modulus, material.poissons_ratio)
    n_nodes = mesh.p.shape[1] + mesh.edges.shape[1]
    pairs, products = summed_blocks(n_nodes, *gradient_products(mesh))
    blocks = lame_lambda * products + shear_modulus * products.swapaxes(0, 1)
    blocks[np.arange(3), np.arange(3)] += shear_modulus * np.trace(products)
    return vector_matrix(n_nodes, pairs, blocks)


def mass_matrix(mesh: MeshTet, material: Material) -> sp.csr_matrix:
    """Consistent mass M, (n_dof, n_dof), kg."""
    return assemble_isotropic(mesh, mass_form(material), intorder=4)


def rigid_body_modes(coordinates: np.ndarray, centre: np.ndarray | None = None) -> np.ndarray:
    """The six rigid-body displacement fields at nodes ``coordinates`` (n, 3) m, as columns (3 n, 6).

    Columns 0-2: unit translations x, y, z (m); 3-5: unit rotations about x, y, z through ``centre``
    (default the centroid of the nodes), u = theta x (X - c) (m per rad).
    """
    arm = coordinates - (coordinates.mean(axis=0) if centre is None else centre)
    modes = np.zeros((coordinates.shape[0], 3, 6))
    modes[:, :, :3] = np.eye(3)
    for axis in range(3):
        modes[:, :, 3 + axis] = np.cross(np.eye(3)[axis], arm)
    return modes.reshape(-1, 6)
