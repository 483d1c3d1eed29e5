"""Prestressed modes of a bolted beam: preload with frictionless contact, stress stiffness, tied modes
(docs/design.md section 3).

Steps, for one beam mesh:

1. Preload: the pretension force pair on the washer couplings (``fem.bolts.preload_forces``) against K plus
   the shanks without their axial stiffness, with frictionless hard contact on the lap (``fem.contact``).
2. Prestress sigma0 from that displacement (Hooke's law) and the stress stiffness
   K_sigma = K_sigma,solid(sigma0) + K_sigma,shanks, the shanks being taut strings carrying the preload P over the
   distance H between the washer reference points (``fem.bolts.shank_stress_stiffness``).
3. Dynamic stiffness K_A = K + K_bolts + K_sigma (K_bolts with the shanks' axial stiffness E A / L), mass
   M + bolt masses, and the modes with the lap tied (``fem.modes.tied_modes``), with and without K_sigma.

Why the shank term is needed. The solid alone is not in equilibrium: the washers press it with P e_z at
z = -H/2 (lower) and -P e_z at z = +H/2 (upper), so the volume integral of sigma0 is sum x (x) f = -3 P H e_z e_z.
For a rigid rotation theta about x or y, grad u = W is constant and K_sigma,solid(u, u) = theta^2 times the
integral of (sigma_yy + sigma_zz) or (sigma_xx + sigma_zz) = -3 P H theta^2: the clamped solid alone would have
unstable rigid rotations (about 12i Hz on the BRB, estimated with its rotary inertia; K - sigma M with the 10 Hz
shift of ``fem.solver.natural_modes`` is then not positive definite and the solve fails). The bolt shanks carry the balancing tension; their stress
stiffness, P / H per lateral relative translation, stores +P H theta^2 per bolt and restores six exact rigid-body
modes.

Sign of the effect on bending. The clamp compresses the lap through its thickness (sigma_zz < 0 under the
washers, a compressive, softening prestress) and the shanks are in tension (stiffening their lateral motion).
On the coarse BRB with the lap tied the net effect lowers the first out-of-plane bending frequency by 1.4e-5
(198.283 -> 198.280 Hz): the prestress is local to the lap and bending barely strains it through the thickness.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from geometry.beam_mesh import BeamMesh, interface_partners

from .bolts import (Bolt, assemble_shanks, bolts_mass, bolts_stiffness, preload_forces, shank_stress_stiffness,
                    washer_couplings)
from .contact import ContactSolution, frictionless_contact, support_321
from .elasticity import Material, mass_matrix, quadratic_node_coordinates, solid_mesh, stiffness_matrix
from .modes import interface_quadratic_pairs, tie_transformation, tied_modes
from .stress_stiffness import prestress_from_displacement, stress_stiffness_matrix


@dataclass(frozen=True)
class PrestressedBeam:
    """The FE model of one beam and its tied modes with and without prestress.

    coordinates: (n_nodes, 3) quadratic node positions, m; stiffness: K of the solid, (n_dof, n_dof) N/m, n_dof =
    3 n_nodes; mass: M of the solid plus the bolt masses, kg; bolts: the shanks with axial stiffness, N/m;
    stress_stiffness: K_sigma of solid and shanks, N/m; contact: the preload solution (``ContactSolution``);
    lower_nodes, upper_nodes: (n_pairs,) interface partner nodes; frequencies, prestressed_frequencies: (n_modes,)
    Hz, tied modes of (K + K_bolts, M) and (K + K_bolts + K_sigma, M), the first six rigid; shapes,
    prestressed_shapes: (n_dof, n_modes) mass-normalised.
    """

    coordinates: np.ndarray
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    bolts: sp.csr_matrix
    stress_stiffness: sp.csr_matrix
    contact: ContactSolution
    lower_nodes: np.ndarray
    upper_nodes: np.ndarray
    frequencies: np.ndarray
    shapes: np.ndarray
    prestressed_frequencies: np.ndarray
    prestressed_shapes: np.ndarray


def prestressed_beam(beam_mesh: BeamMesh, beam, material: Material = Material(), bolt: Bolt = Bolt(),
                     n_modes: int = 10, method: str | None = None) -> PrestressedBeam:
    """Assemble, preload with contact and solve the tied modes of one beam (steps 1-3 of the module docstring).

    beam_mesh: ``geometry.beam_mesh.BeamMesh``; beam: its ``geometry.parameters.BeamParameters`` (bolt positions,
    section height H); n_modes: modes per solve, including the six rigid ones; method: factorisation
    (``fem.solver.factorize``).
    """
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    coordinates = quadratic_node_coordinates(mesh)
    stiffness = stiffness_matrix(mesh, material)
    couplings = washer_couplings(mesh, beam_mesh, beam)
    lower, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    supported = support_321(coordinates, np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    contact = frictionless_contact(stiffness + bolts_stiffness(couplings, bolt, axial=False),
                                   preload_forces(couplings, bolt), lower, upper, supported, method=method)
    stress_stiffness = (stress_stiffness_matrix(mesh, prestress_from_displacement(contact.displacement, material))
                        + assemble_shanks(couplings, shank_stress_stiffness(bolt.preload, beam.height))).tocsr()
    bolts = bolts_stiffness(couplings, bolt)
    mass = (mass_matrix(mesh, material) + bolts_mass(couplings, bolt)).tocsr()
    tie = tie_transformation(stiffness.shape[0], lower, upper)
    frequencies, shapes = tied_modes(stiffness + bolts, mass, tie, n_modes, method)
    prestressed_frequencies, prestressed_shapes = tied_modes(stiffness + bolts + stress_stiffness, mass, tie,
                                                             n_modes, method)
    return PrestressedBeam(coordinates, stiffness, mass, bolts, stress_stiffness, contact, lower, upper,
                           frequencies, shapes, prestressed_frequencies, prestressed_shapes)
