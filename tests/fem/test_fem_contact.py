"""Bolt preload with frictionless contact on the coarse BRB mesh (about 15 s)."""

import numpy as np
import pytest

from fem.bolts import Bolt, bolts_stiffness, preload_forces, washer_couplings
from fem.contact import frictionless_contact, support_321
from fem.elasticity import Material, quadratic_node_coordinates, rigid_body_modes, solid_mesh, stiffness_matrix
from fem.modes import interface_quadratic_pairs
from geometry.beam_mesh import interface_partners
from geometry.parameters import BEAMS

BEAM = BEAMS["BRB"]


@pytest.fixture(scope="module")
def preloaded(coarse_brb):
    beam_mesh = coarse_brb
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    coordinates = quadratic_node_coordinates(mesh)
    stiffness = stiffness_matrix(mesh, Material())
    couplings = washer_couplings(mesh, beam_mesh, BEAM)
    bolt = Bolt()
    lower, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    supported = support_321(coordinates, np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    forces = preload_forces(couplings, bolt)
    solution = frictionless_contact(stiffness + bolts_stiffness(couplings, bolt, axial=False), forces,
                                    lower, upper, supported)
    return coordinates, couplings, forces, lower, solution


def test_coupling_returns_the_rigid_motion_of_its_footprint(preloaded):
    coordinates, couplings, _, _, _ = preloaded
    for lower, upper in couplings:
        for coupling in (lower, upper):
            reference = coupling[:3] @ rigid_body_modes(coordinates, np.zeros(3))[:, :3]
            np.testing.assert_allclose(reference, np.eye(3), atol=1e-12)


def test_preload_is_self_equilibrated_and_the_support_carries_nothing(preloaded):
    coordinates, _, forces, _, solution = preloaded
    resultant = rigid_body_modes(coordinates, np.zeros(3)).T @ forces  # forces N, moments N m
    assert np.abs(resultant).max() < 1e-12 * Bolt().preload
    assert np.abs(solution.reactions).max() < 1e-8 * Bolt().preload


def test_contact_forces_sum_to_the_three_preloads_without_penetration_or_tension(preloaded):
    _, _, _, _, solution = preloaded
    # The shank carries exactly the pretension (force pair, no axial shank stiffness in this step), so normal
    # equilibrium of the upper half makes the contact forces sum to it; only round-off remains.
    np.testing.assert_allclose(solution.normal_force.sum(), 3 * Bolt().preload, rtol=1e-3)
    assert solution.normal_force.min() >= 0.0
    assert solution.gap.min() > -1e-12 * BEAM.height
    assert np.all(solution.gap[solution.active] == 0.0)


def test_contact_pressure_concentrates_around_the_bolts(preloaded):
    """A 30 degree frustum from the washer edge through the 12.7 mm half thickness reaches 16.1 mm from the axis
    at the interface: most of the clamp force lies inside those circles and the lap ends lift off."""
    coordinates, _, _, lower, solution = preloaded
    positions = coordinates[lower]
    frustum = BEAM.washer_outer_diameter / 2 + BEAM.lap_thickness * np.tan(np.radians(30))
    distance = np.min([np.hypot(positions[:, 0] - x, positions[:, 1]) for x in BEAM.bolt_x], axis=0)
    inside = solution.normal_force[distance < frustum].sum() / solution.normal_force.sum()
    assert inside > 0.9
    lap_end = np.abs(positions[:, 0]) > BEAM.lap_length / 2 - 0.01
    assert not solution.active[lap_end].any()
    assert 0.4 < solution.active.mean() < 0.8


@pytest.mark.slow
def test_superlu_fallback_gives_the_same_contact_state(coarse_brb, preloaded):
    """The fallback factorisation (no symbolic reuse) reaches the same active set and contact forces (about 45 s:
    SuperLU refactorises every active-set iteration)."""
    coordinates, couplings, forces, lower, solution = preloaded
    beam_mesh = coarse_brb
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    _, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    supported = support_321(coordinates, np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    stiffness = stiffness_matrix(mesh, Material()) + bolts_stiffness(couplings, Bolt(), axial=False)
    fallback = frictionless_contact(stiffness, forces, lower, upper, supported, method="superlu")
    np.testing.assert_array_equal(fallback.active, solution.active)
    np.testing.assert_allclose(fallback.normal_force, solution.normal_force, rtol=0,
                               atol=1e-9 * solution.normal_force.max())
