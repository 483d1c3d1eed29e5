"""CalculiX cross-check of the tied-interface frequencies on the coarse BRB mesh (ccx about 6 s)."""

import numpy as np
import pytest

from fem.calculix import c3d10_connectivity, calculix_available, read_frequencies, run_calculix, tied_frequency_deck
from fem.elasticity import DECK_MATERIAL, mass_matrix, quadratic_node_coordinates, solid_mesh, stiffness_matrix
from fem.modes import interface_quadratic_pairs, tie_transformation, tied_modes
from geometry.beam_mesh import interface_partners



@pytest.fixture(scope="module")
def brb(coarse_brb):
    beam_mesh = coarse_brb
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    return mesh, interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))


def test_c3d10_mid_side_nodes_sit_at_their_edge_midpoints_with_positive_volume(brb):
    mesh, _ = brb
    nodes = quadratic_node_coordinates(mesh)[c3d10_connectivity(mesh)]  # (n_elements, 10, 3)
    corners = nodes[:, :4]
    for mid, (a, b) in enumerate(((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))):
        np.testing.assert_allclose(nodes[:, 4 + mid], 0.5 * (corners[:, a] + corners[:, b]), atol=1e-15)
    edges = corners[:, 1:] - corners[:, :1]
    assert np.all(np.einsum("ei,ei->e", np.cross(edges[:, 0], edges[:, 1]), edges[:, 2]) > 0)


@pytest.mark.skipif(not calculix_available(), reason="CalculiX absent: apt-get install -y calculix-ccx")
def test_calculix_c3d10_gives_the_same_tied_frequencies(brb, tmp_path):
    """Same mesh, same material, same tie: C3D10 is the quadratic tetrahedron, so the first ten flexible modes
    agree to the solvers' precision (ccx prints 7 digits; its Lanczos tolerance leaves a few 1e-6)."""
    mesh, (lower, upper) = brb
    n_modes = 16
    stiffness, mass = stiffness_matrix(mesh, DECK_MATERIAL), mass_matrix(mesh, DECK_MATERIAL)
    ours, _ = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), n_modes)
    dat = run_calculix(tied_frequency_deck(mesh, DECK_MATERIAL, lower, upper, n_modes), tmp_path)
    theirs = read_frequencies(dat)
    assert len(theirs) == n_modes
    assert np.all(np.abs(theirs[:6]) < 1e-4 * theirs[6])
    np.testing.assert_allclose(ours[6:], theirs[6:], rtol=1e-5)
