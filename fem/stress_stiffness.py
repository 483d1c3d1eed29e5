"""Stress (geometric) stiffness of a prestressed solid, K_sigma, and the dynamic stiffness K_A = K + K_sigma.

K_sigma(u, v) = integral of grad(v) : (sigma0 grad(u)) dV = sum_ijk sigma0_ij d_i u_k d_j v_k dV
(docs/design.md section 3), sigma0 the prestress (Pa), here evaluated at the quadrature points of each element chunk.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, CellBasis, MeshTet
from skfem.helpers import dot, mul, trace
from skfem.models.elasticity import lame_parameters

from .elasticity import Material, assemble_isotropic

Prestress = Callable[[CellBasis], np.ndarray]
"""Prestress at a chunk's quadrature points: basis -> sigma0, (3, 3, n_elements, n_points), Pa."""


@BilinearForm
def stress_stiffness_form(u, v, w):
    """Geometric stiffness of one displacement component: grad(v) . (sigma0 grad(u)), sigma0 read from
    ``w.prestress``, N/m. The vector form sum_ijk sigma0_ij d_i u_k d_j v_k acts alike on each component k."""
    return dot(mul(w.prestress, u.grad), v.grad)


def uniform_prestress(stress: np.ndarray) -> Prestress:
    """A spatially constant prestress tensor ``stress`` (3, 3), Pa."""
    stress = np.asarray(stress, dtype=float)

    def prestress(basis: CellBasis) -> np.ndarray:
        return np.broadcast_to(stress[:, :, None, None], (3, 3, basis.nelems, len(basis.W))).copy()
    return prestress


def prestress_from_displacement(displacement: np.ndarray, material: Material) -> Prestress:
    """Hooke's-law stress sigma0 = lambda tr(eps) I + 2 mu eps of a static displacement (n_dof,) m, at the
    quadrature points of a scalar quadratic basis (``fem.elasticity.node_basis_chunks``)."""
    lame_lambda, shear_modulus = lame_parameters(material.youngs_modulus, material.poissons_ratio)

    components = np.reshape(displacement, (-1, 3)).T

    def prestress(basis: CellBasis) -> np.ndarray:
        gradient = np.stack([basis.interpolate(component).grad for component in components])  # d_j u_i
        strain = 0.5 * (gradient + np.swapaxes(gradient, 0, 1))
        return lame_lambda * trace(strain) * np.eye(3)[:, :, None, None] + 2 * shear_modulus * strain
    return prestress


def stress_stiffness_matrix(mesh: MeshTet, prestress: Prestress) -> sp.csr_matrix:
    """K_sigma, (n_dof, n_dof), N/m. Quadrature of degree 3 integrates a linear sigma0 times two gradients of
    straight-sided quadratic elements exactly."""
    return assemble_isotropic(mesh, stress_stiffness_form, intorder=3,
                              fields=lambda basis: {"prestress": prestress(basis)})
