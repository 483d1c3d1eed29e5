"""Tied-interface modes of the coarse BRB mesh (about 26k DOF, a few seconds)."""

import numpy as np
import pytest

from fem.elasticity import Material, mass_matrix, quadratic_node_coordinates, solid_mesh, stiffness_matrix
from fem.modes import interface_quadratic_pairs, tie_transformation, tied_modes
from fem.solver import natural_modes
from geometry.beam_mesh import interface_partners



@pytest.fixture(scope="module")
def brb(coarse_brb):
    beam_mesh = coarse_brb
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    lower, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    material = Material()
    return mesh, stiffness_matrix(mesh, material), mass_matrix(mesh, material), lower, upper


def test_interface_partners_coincide_and_include_edge_midpoints(brb):
    mesh, _, _, lower, upper = brb
    coordinates = quadratic_node_coordinates(mesh)
    np.testing.assert_allclose(coordinates[lower], coordinates[upper], atol=1e-12)
    np.testing.assert_allclose(coordinates[lower][:, 2], 0.0, atol=1e-12)
    n_vertices = mesh.p.shape[1]
    assert np.count_nonzero(lower >= n_vertices) > np.count_nonzero(lower < n_vertices)  # triangulation: E > V


def test_tied_beam_has_six_rigid_modes_and_untied_halves_twelve(brb):
    mesh, stiffness, mass, lower, upper = brb
    tied, _ = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), 8)
    untied, _ = natural_modes(stiffness, mass, 14)
    # Rigid eigenvalues are round-off of the factorised K - sigma M: 1e-8 of the first elastic one, i.e.
    # frequencies below 1e-4 of the first elastic frequency.
    assert np.all(np.abs(tied[:6]) < 1e-4 * tied[6])
    assert tied[6] > 100.0
    assert np.all(np.abs(untied[:12]) < 1e-4 * untied[12])
    assert untied[12] > 100.0


def test_tied_first_bending_is_below_the_solid_bar(brb):
    """The tied BRB is the full 720.85 mm bar less the bolt holes: free-free Euler-Bernoulli 248 Hz for the solid
    bar. Holes through the lap make the beam softer, and the coarse mesh stiffer: within 15-25 % below."""
    mesh, stiffness, mass, lower, upper = brb
    frequencies, shapes = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), 8)
    section, length, material = 0.0254, 2 * 0.29972 + 0.12141, Material()
    solid_bar = 4.730040745 ** 2 / (2 * np.pi * length ** 2) * np.sqrt(
        material.youngs_modulus * section ** 2 / (12 * material.density))
    assert 0.75 * solid_bar < frequencies[6] < 0.85 * solid_bar
    bending = shapes[:, 6].reshape(-1, 3)
    # Out-of-plane (z) bending, normal to the lap, is the first elastic mode.
    assert np.linalg.norm(bending[:, 2]) > 10 * np.linalg.norm(bending[:, 1])


def test_modes_are_reproducible_to_the_last_bit(brb):
    """A fixed Lanczos start vector and the sign convention (largest entry positive): the same matrices give the
    same floats twice, so the FE files keep their hashes and the reduction's cache holds."""
    _, stiffness, mass, lower, upper = brb
    first = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), 8)
    second = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), 8)
    for a, b in zip(first, second):
        assert np.array_equal(a, b)
    shapes = first[1]
    assert np.all(shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])] > 0)
