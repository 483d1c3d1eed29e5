"""Elasticity, mass and eigen-solver of the finite-element stage on analytic cases and the coarse BRB mesh."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pytest
from skfem import MeshTet

from fem.elasticity import DECK_MATERIAL, Material, mass_matrix, quadratic_node_coordinates, rigid_body_modes, \
    solid_mesh, stiffness_matrix
from fem.solver import factorization_name, natural_modes
from geometry.properties import tetrahedron_volumes

SECTION = 0.0254  # m, the BRB's square section


def bar_mesh(length: float, n_length: int, n_section: int) -> MeshTet:
    """Straight-sided tetrahedral mesh of a square bar along x, section SECTION x SECTION."""
    section = np.linspace(0.0, SECTION, n_section + 1)
    return MeshTet.init_tensor(np.linspace(0.0, length, n_length + 1), section, section)


def test_mass_matrix_holds_density_times_volume_for_each_translation():
    mesh = bar_mesh(0.3, 6, 2)
    mass = mass_matrix(mesh, DECK_MATERIAL)
    translations = rigid_body_modes(quadratic_node_coordinates(mesh))[:, :3]
    expected = DECK_MATERIAL.density * tetrahedron_volumes(mesh.p.T, mesh.t.T).sum()
    # Quadratic shape functions sum to one, so 1^T M 1 = integral of rho exactly (to round-off).
    np.testing.assert_allclose(np.diag(translations.T @ mass @ translations), expected, rtol=1e-12)


def test_stiffness_does_no_work_in_rigid_body_motion():
    mesh = bar_mesh(0.3, 6, 2)
    stiffness = stiffness_matrix(mesh, Material())
    rigid = rigid_body_modes(quadratic_node_coordinates(mesh))
    # Rigid motions are in the quadratic space and strain-free: K R vanishes to round-off of |K| |R|.
    scale = abs(stiffness).sum(axis=1).max() * np.abs(rigid).max()
    assert np.abs(stiffness @ rigid).max() < 1e-12 * scale


def test_free_free_bar_first_bending_matches_timoshenko():
    """L/h = 20: shear and rotary inertia lower Euler-Bernoulli by 0.94 %; the first-order Timoshenko
    correction leaves second-order terms (about 1e-4) and the discretisation error of a 2 x 2 section."""
    length, material = 20 * SECTION, Material()
    mesh = bar_mesh(length, 40, 2)
    frequencies, _ = natural_modes(stiffness_matrix(mesh, material), mass_matrix(mesh, material), 10)
    youngs, rho, nu = material.youngs_modulus, material.density, material.poissons_ratio
    beta_length = 4.730040745  # first root of cos(x) cosh(x) = 1
    euler_bernoulli = beta_length ** 2 / (2 * np.pi * length ** 2) * np.sqrt(youngs * SECTION ** 2 / (12 * rho))
    shear_coefficient = 10 * (1 + nu) / (12 + 11 * nu)  # Cowper, rectangular section
    shear_and_rotary = 0.5 * beta_length ** 2 * SECTION ** 2 / (12 * length ** 2) * (
        1 + 2 * (1 + nu) / shear_coefficient)
    timoshenko = euler_bernoulli * (1 - shear_and_rotary)
    assert np.all(np.abs(frequencies[:6]) < 1e-4 * frequencies[6])
    # Both bending planes (square section) give the same first frequency.
    np.testing.assert_allclose(frequencies[6:8], timoshenko, rtol=1.5e-3)
    assert abs(frequencies[6] - euler_bernoulli) > 5e-3 * euler_bernoulli


@pytest.mark.parametrize("method", ["superlu", "cholmod"])
def test_factorisations_give_the_same_modes(method):
    if method == "cholmod" and factorization_name() != "cholmod":
        pytest.skip("scikit-sparse (CHOLMOD) not importable here: install scikit-sparse<0.5 with libsuitesparse-dev")
    mesh = bar_mesh(0.3, 12, 2)
    stiffness, mass = stiffness_matrix(mesh, Material()), mass_matrix(mesh, Material())
    reference, _ = natural_modes(stiffness, mass, 10, method="superlu")
    frequencies, shapes = natural_modes(stiffness, mass, 10, method=method)
    np.testing.assert_allclose(frequencies[6:], reference[6:], rtol=1e-9)
    np.testing.assert_allclose(shapes.T @ mass @ shapes, np.eye(10), atol=1e-9)


def test_solid_mesh_keeps_node_numbering_and_drops_mid_side_nodes():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    edges = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [2, 3], [1, 3]])
    points10 = np.vstack([points, points[edges].mean(axis=1)])
    mesh = solid_mesh(points10, np.arange(10)[None, :])
    np.testing.assert_array_equal(mesh.t[:, 0], [0, 1, 2, 3])
    np.testing.assert_allclose(mesh.p.T[:4], points)


@pytest.mark.parametrize("chunk_elements", [7, 20000])
def test_block_assembly_equals_scikit_fem_vector_forms(chunk_elements, monkeypatch):
    """The scalar-block assembly (``fem.elasticity.gradient_products`` / ``assemble_isotropic``) against
    scikit-fem's own vector forms on the same quadratic space, in one element chunk or many: linear
    elasticity, mass and a stress stiffness with a full prestress tensor, equal to round-off."""
    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector
    from skfem.helpers import ddot, dot, grad, mul
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from fem.stress_stiffness import stress_stiffness_matrix, uniform_prestress

    monkeypatch.setattr("fem.elasticity.CHUNK_ELEMENTS", chunk_elements)
    mesh = bar_mesh(0.1, 3, 2)
    material = Material()
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=4)
    stress = np.array([[3.0, 1.0, -2.0], [1.0, -5.0, 0.5], [-2.0, 0.5, 4.0]]) * 1e6

    @BilinearForm
    def vector_mass(u, v, w):
        return material.density * dot(u, v)

    @BilinearForm
    def vector_stress_stiffness(u, v, w):
        return ddot(mul(grad(v), stress[:, :, None, None]), grad(u))

    cases = [(stiffness_matrix(mesh, material), linear_elasticity(*lame_parameters(material.youngs_modulus,
                                                                                   material.poissons_ratio))),
             (mass_matrix(mesh, material), vector_mass),
             (stress_stiffness_matrix(mesh, uniform_prestress(stress)), vector_stress_stiffness)]
    for ours, form in cases:
        reference = form.assemble(basis)
        assert abs(ours - reference).max() <= 1e-12 * abs(reference).max()
