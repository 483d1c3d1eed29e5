"""CalculiX cross-checks on the coarse BRB mesh: tied-interface frequencies (ccx about 6 s) and the bolt preload
with frictionless contact (ccx about 20 s)."""

import numpy as np
import pytest

from fem.bolts import Bolt, bolts_stiffness, preload_forces, quadratic_triangles, washer_couplings
from fem.calculix import (bolt_elongations, c3d10_connectivity, calculix_available, in_plane_support,
                          preload_contact_deck, read_frequencies, read_node_values, run_calculix,
                          spring_initial_forces, tied_frequency_deck)
from fem.contact import frictionless_contact, support_321
from fem.coupling import nodal_areas
from fem.elasticity import (DECK_MATERIAL, Material, mass_matrix, quadratic_node_coordinates, solid_mesh,
                            stiffness_matrix)
from fem.modes import interface_quadratic_pairs, tie_transformation, tied_modes
from fem.render import SUBTRIANGLES, nodal_pressure
from geometry.beam_mesh import interface_partners
from geometry.parameters import BEAMS

BEAM = BEAMS["BRB"]
calculix = pytest.mark.skipif(not calculix_available(), reason="CalculiX absent: apt-get install -y calculix-ccx")


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


@calculix
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


@pytest.fixture(scope="module")
def preload_both(coarse_brb, tmp_path_factory):
    """Our pretension solve with frictionless node-pair contact, and CalculiX's on the same mesh (ccx about 20 s).

    Returns a dict: ours (``ContactSolution``), contact forces (n_pairs,) N and gaps (n_pairs,) m of ccx (the
    contact force on an upper interface node is the solid's internal force K u there, u read from the .dat: the
    same C3D10 stiffness, see the frequency test; ccx's own ``RF`` includes the contact elements and sums to zero,
    its ``CSTR`` divides by its own slave-node areas), ccx's spring forces (n_bolts,) N, interface node positions
    (n_pairs, 3) m, consistent and tributary nodal areas (n_pairs,) m^2 (tributary: of the four three-node
    sub-triangles, so that every node has a share of the lap).
    """
    beam_mesh = coarse_brb
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    coordinates = quadratic_node_coordinates(mesh)
    stiffness = stiffness_matrix(mesh, Material())
    couplings, bolt = washer_couplings(mesh, beam_mesh, BEAM), Bolt()
    lower, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    supported = support_321(coordinates, np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    ours = frictionless_contact(stiffness + bolts_stiffness(couplings, bolt, axial=False),
                                preload_forces(couplings, bolt), lower, upper, supported)
    initial_forces = spring_initial_forces(bolt, bolt_elongations(couplings, ours.displacement))
    upper_support = in_plane_support(support_321(coordinates, np.unique(beam_mesh.volumes["upper_half"][:, :4])))
    deck = preload_contact_deck(mesh, beam_mesh, BEAM, Material(), bolt, initial_forces,
                                np.concatenate([supported, upper_support]))
    dat = run_calculix(deck, tmp_path_factory.mktemp("ccx_preload"))
    ids, values = read_node_values(dat, "displacements", "SOLID_NODES")
    displacement = np.zeros(stiffness.shape[0])
    displacement[3 * (ids - 1)[:, None] + np.arange(3)] = values
    _, references = read_node_values(dat, "displacements", "REFERENCES")
    springs = initial_forces + bolt.axial_stiffness * (references[1::2, 2] - references[0::2, 2])
    triangles = quadratic_triangles(mesh, beam_mesh.faces["lower_interface"])
    return {"ours": ours, "forces": (stiffness @ displacement)[3 * upper + 2],
            "gaps": displacement[3 * upper + 2] - displacement[3 * lower + 2], "springs": springs,
            "positions": coordinates[lower], "areas": nodal_areas(coordinates, triangles)[lower],
            "tributary": nodal_areas(coordinates, triangles[:, SUBTRIANGLES].reshape(-1, 3))[lower]}


def bolt_distances(positions: np.ndarray) -> np.ndarray:
    """Distance (n,) m of each interface point (n, 3) from the nearest bolt axis."""
    return np.min([np.hypot(positions[:, 0] - x, positions[:, 1]) for x in BEAM.bolt_x], axis=0)


def without_contact_element(forces: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """ccx pairs (n,) bool that carry no force (below 0.1 % of the largest) yet penetrate deeper than any pair
    carrying more than 1 % of it: penalty contact carries force in proportion to penetration, so these slave nodes
    have no contact element. forces: (n,) N, gaps: (n,) m."""
    deepest = gaps[forces > 1e-2 * forces.max()].min()
    return (np.abs(forces) < 1e-3 * forces.max()) & (gaps < deepest)


@calculix
def test_calculix_springs_clamp_with_the_preload_and_the_contact_forces_sum_to_it(preload_both):
    """The springs start at F0 = P - (E A / L) e_ours: they clamp with exactly P only if ccx's bolt stack is as
    compliant as ours (0.1 % of P is 0.6 % of the 5.2 um shortening); the penalty adds 1e-4 of that compliance."""
    preload = Bolt().preload
    np.testing.assert_allclose(preload_both["springs"], preload, rtol=1e-3)
    np.testing.assert_allclose(preload_both["forces"].sum(), 3 * preload, rtol=1e-3)
    np.testing.assert_allclose(preload_both["ours"].normal_force.sum(), 3 * preload, rtol=1e-3)


@calculix
def test_calculix_closes_the_same_part_of_the_lap(preload_both):
    """Closed: our active pairs; ccx's penetrating ones (penalty contact carries force only where it penetrates).
    Only pairs at the edge of the contact zone, where the force vanishes, may differ: at most 1 % of the pairs."""
    ours, tributary = preload_both["ours"].active, preload_both["tributary"]
    theirs = preload_both["gaps"] < 0
    assert np.count_nonzero(ours != theirs) <= 0.01 * len(ours)
    np.testing.assert_allclose(tributary[theirs].sum(), tributary[ours].sum(), rtol=0.01)
    assert 0.55 < tributary[ours].sum() / tributary.sum() < 0.7


@calculix
def test_calculix_contact_forces_follow_ours_pair_by_pair(preload_both):
    """ccx's node-to-surface search leaves a few slave nodes exactly on the bolt-hole rims (the boundary edges of
    the master surface) without a contact element: they penetrate freely and their force (about 30 N, under 0.1 %
    of the clamp) goes to their neighbours. Away from those (4 mm, about one element) node-to-surface on coincident
    nodes is our node-pair constraint plus a penalty: the solid's stiffness at a node, E h = 190 GPa x 3 mm =
    6e8 N/m, is 4e-3 of the node's contact spring K a_i = 1e17 N/m^3 x 1.5e-6 m^2, hence 0.5 % (relative 2-norm;
    measured away from the rims 3.6 %, 1.7 %, 0.31 % at penalties 1e15, 1e16, 1e17 N/m^3: it is the penalty).
    So: the nodal forces differ by at most twice the lost forces (lost, then found at the neighbours) plus 0.5 %;
    the force per 2 mm ring about the bolts by at most the lost forces plus 0.5 %."""
    ours, theirs = preload_both["ours"].normal_force, preload_both["forces"]
    positions, distance = preload_both["positions"], bolt_distances(preload_both["positions"])
    lost = without_contact_element(theirs, preload_both["gaps"])
    np.testing.assert_allclose(distance[lost], BEAM.hole_diameter / 2, rtol=1e-6)
    assert 0 < np.count_nonzero(lost) <= 12 and ours[lost].sum() < 1e-3 * ours.sum()
    near = np.min([np.linalg.norm(positions - positions[i], axis=1) for i in np.flatnonzero(lost)], axis=0) < 4e-3
    assert np.linalg.norm((theirs - ours)[~near]) < 5e-3 * np.linalg.norm(ours)
    assert np.linalg.norm(theirs - ours) < 2 * np.linalg.norm(ours[lost]) + 5e-3 * np.linalg.norm(ours)
    rings = np.digitize(distance, np.arange(BEAM.hole_diameter / 2, 0.02, 0.002))
    np.testing.assert_allclose(np.bincount(rings, theirs), np.bincount(rings, ours), rtol=5e-3,
                               atol=ours[lost].sum())


@calculix
def test_calculix_peak_pressure_is_ours_beside_a_rim_node(preload_both):
    """Pressure N_i / a_i at the mid-side nodes (consistent areas, ``fem.render.nodal_pressure``). Both peaks are
    at the same node, beside a rim node without contact element in ccx (previous test) whose load it takes up:
    within 5 % (that rim node carries 10 N in ours, the peak node 90 N)."""
    ours = nodal_pressure(preload_both["ours"].normal_force, preload_both["areas"])
    theirs = nodal_pressure(preload_both["forces"], preload_both["areas"])
    peak = np.nanargmax(ours)
    assert np.nanargmax(theirs) == peak
    np.testing.assert_allclose(theirs[peak], ours[peak], rtol=0.05)
    lost = without_contact_element(preload_both["forces"], preload_both["gaps"])
    positions = preload_both["positions"]
    assert np.linalg.norm(positions[lost] - positions[peak], axis=1).min() < 4e-3
