"""Linear elasticity of the beam meshes: stiffness K and consistent mass M with quadratic tetrahedra.

The geometry stage writes 4-node tetrahedra (or gmsh 10-node ones with straight sides); here only their corners
are used and scikit-fem's quadratic Lagrange tetrahedron (``ElementTetP2``, mid-side nodes at the straight
edge midpoints) is built on them, three displacement components per node (DESIGN section 3).

Degrees of freedom follow scikit-fem's vector numbering: the "quadratic nodes" are the mesh vertices
(0..n_vertices-1) followed by the edge midpoints (in ``mesh.edges`` order), and the DOF of component k
(0: x, 1: y, 2: z) at quadratic node p is 3 p + k.

Forms are assembled over element chunks so that the quadrature-point arrays of one chunk, not of the whole
mesh, are held in memory at a time (about 3 GB peak at any mesh size for the default chunk).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, CellBasis, ElementTetP2, ElementVector, MeshTet
from skfem.helpers import ddot, dot, sym_grad, trace
from skfem.models.elasticity import lame_parameters

CHUNK_ELEMENTS = 4000


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material: Young's modulus Pa, Poisson's ratio, density kg/m^3."""

    youngs_modulus: float = 190e9
    poissons_ratio: float = 0.29
    density: float = 7800.0


#: The material of the public BRB ABAQUS input deck (DESIGN section 3); the default is ``Material()``.
DECK_MATERIAL = Material(youngs_modulus=192.85e9, poissons_ratio=0.29, density=7857.8)


def solid_mesh(points: np.ndarray, tetrahedra: np.ndarray) -> MeshTet:
    """The straight-sided tetrahedral mesh of the solid from node coordinates (n, 3) m and tetrahedra (m, >=4).

    Only the four corner columns of ``tetrahedra`` are used (gmsh order: corners first), so a 10-node input gives
    the same mesh as its 4-node corners. Node indices are kept: vertex i of the result is ``points[i]``.
    """
    return MeshTet(np.ascontiguousarray(points.T, dtype=float),
                   np.ascontiguousarray(tetrahedra[:, :4].T, dtype=np.int64))


def displacement_element() -> ElementVector:
    """The quadratic (10-node) Lagrange tetrahedron with three displacement components per node."""
    return ElementVector(ElementTetP2())


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


def assemble(mesh: MeshTet, form: BilinearForm, intorder: int,
             fields: Callable[[CellBasis], dict] | None = None,
             chunk_elements: int = CHUNK_ELEMENTS) -> sp.csr_matrix:
    """Assemble a bilinear form over the quadratic displacement space, element chunk by element chunk.

    intorder: degree of polynomials the tetrahedron quadrature integrates exactly (2: products of gradients of
        straight-sided quadratic elements, 4: products of the shape functions).
    fields: optional function of a chunk's basis returning the keyword fields the form reads from ``w``
        (e.g. the prestress at that chunk's quadrature points).
    Returns the (3 n_nodes, 3 n_nodes) CSR matrix, n_nodes = n_vertices + n_edges.
    """
    element = displacement_element()
    whole = CellBasis(mesh, element, elements=np.arange(1), disable_doflocs=True)
    parts = []
    for start in range(0, mesh.t.shape[1], chunk_elements):
        chunk = np.arange(start, min(start + chunk_elements, mesh.t.shape[1]))
        basis = CellBasis(mesh, element, intorder=intorder, elements=chunk, dofs=whole.dofs,
                          disable_doflocs=True)
        parts.append(form.assemble(basis, **(fields(basis) if fields else {})))
    return sum(parts[1:], parts[0]).tocsr()


def stiffness_form(material: Material) -> BilinearForm:
    """Linear elasticity: integral of (lambda tr eps(u) tr eps(v) + 2 mu eps(u) : eps(v)) dV, N/m."""
    lame_lambda, shear_modulus = lame_parameters(material.youngs_modulus, material.poissons_ratio)

    @BilinearForm
    def stiffness(u, v, w):
        strain_u, strain_v = sym_grad(u), sym_grad(v)
        return lame_lambda * trace(strain_u) * trace(strain_v) + 2 * shear_modulus * ddot(strain_u, strain_v)
    return stiffness


def mass_form(material: Material) -> BilinearForm:
    """Consistent mass: integral of rho u . v dV, kg."""
    @BilinearForm
    def mass(u, v, w):
        return material.density * dot(u, v)
    return mass


def stiffness_matrix(mesh: MeshTet, material: Material) -> sp.csr_matrix:
    """Elastic stiffness K, (n_dof, n_dof), N/m."""
    return assemble(mesh, stiffness_form(material), intorder=2)


def mass_matrix(mesh: MeshTet, material: Material) -> sp.csr_matrix:
    """Consistent mass M, (n_dof, n_dof), kg."""
    return assemble(mesh, mass_form(material), intorder=4)


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
