"""The whole-joint superelement of one beam: patch virtual nodes, Hurty/Craig-Bampton, sensors (paper 4.1).

What the superelement holds (docs/design.md section 4: two free halves, 12 zero-energy modes until joint elements
connect them):
- both halves' solid stiffness and mass, and the bolt, nut and washer mass (28.64 g per bolt, half on each
  washer footprint, ``fem.bolts.bolts_mass``): the total mass, centre of mass and inertia are the full model's;
- not the bolt shanks' stiffness. In the whole-joint model the patch elements represent the whole joint: the
  normal spring K_z of a patch is the bolt and the clamped members in series (paper Eq. 31, K_b + K_m, "the
  total normal stiffness of each joint"), and the bolts' shear and bending stiffness is part of the identified
  tangential behaviour. Keeping the shanks would join the halves in parallel with every joint design.
- Prestress: K_A = K + K_sigma of the clamped halves, on the same basis as K. The shanks' own stress stiffness
  (taut strings, ``fem.bolts.shank_stress_stiffness``) joins the halves and belongs to the bolts, i.e. to the
  joint; it is reduced separately (``bolt_string_stiffness``). The clamp's loads on each half are balanced only
  by that string term and the joint: the stress stiffness of the dead-loaded halves gives each free half
  -3 P H / 2 = -441 N m/rad about x and y (``fem.prestress``), so the free prestressed superelement is
  indefinite, with four unstable modes (246i Hz about x, where a half's rotary inertia is only 2e-4 kg m^2, and
  22i Hz about y, on the BRB). K_A + strings + joint springs reproduces the full prestressed model. Because
  K_sigma moves the bending frequencies by only about 1e-5 (``fem.prestress``) and a joint stage must keep those
  negative eigenvalues rather than treat them as rigid modes, the superelement's default stiffness is K; K_A
  and the string term are stored beside it.

Reduced coordinates (86): lower virtual nodes 1-5, upper virtual nodes 1-5 (6 DOFs each, about the patch
centroids, which the two sides share), then 26 fixed-interface modal coordinates (``craig_bampton``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import MeshTet

from fem.bolts import Bolt, assemble_shanks, preload_forces, shank_stress_stiffness, washer_couplings
from fem.contact import support_321
from fem.elasticity import quadratic_node_coordinates
from fem.springs import N_PATCHES, patch_couplings
from geometry.beam_mesh import BeamMesh
from geometry.parameters import BeamParameters
from geometry.properties import face_second_moments, triangle_areas

from .craig_bampton import (N_FIXED_INTERFACE_MODES, HurtyCraigBampton, PatchLayoutError, boundary_constraints,
                            half_rigid_modes, hurty_craig_bampton, relative_patch_motion)
from .superelement import Superelement

_PATCH_NAME = re.compile(r"(lower|upper)_patch_(\d+)$")


def check_patch_layout(beam_mesh: BeamMesh) -> int:
    """Number of patch pairs of a beam mesh; PatchLayoutError unless both sides have the same, consecutively
    numbered ``N_PATCHES`` patches (``fem.springs.patch_couplings`` pairs them by number)."""
    numbers = {"lower": set(), "upper": set()}
    for name in beam_mesh.faces:
        match = _PATCH_NAME.match(name)
        if match:
            numbers[match.group(1)].add(int(match.group(2)))
    if numbers["lower"] != numbers["upper"]:
        raise PatchLayoutError(f"mesh has lower patches {sorted(numbers['lower'])} and upper patches "
                               f"{sorted(numbers['upper'])}: every patch needs its partner on the other side")
    if numbers["lower"] != set(range(1, N_PATCHES + 1)):
        raise PatchLayoutError(f"mesh has patches {sorted(numbers['lower'])} per side; expected 1..{N_PATCHES}")
    return N_PATCHES


def quadratic_node_halves(mesh: MeshTet, beam_mesh: BeamMesh) -> np.ndarray:
    """Half of each quadratic node (vertices, then edge midpoints), (n_nodes,): 0 lower, 1 upper. An edge lies in
    one half (the halves are separate bodies), so a midpoint belongs to the half of its first vertex."""
    vertex_half = np.full(mesh.p.shape[1], -1)
    for half, name in enumerate(("lower_half", "upper_half")):
        vertex_half[np.unique(beam_mesh.volumes[name][:, :4])] = half
    return np.concatenate([vertex_half, vertex_half[mesh.edges[0]]])


def half_supports(coordinates: np.ndarray, mesh: MeshTet, halves: np.ndarray) -> np.ndarray:
    """Statically determinate (3-2-1) supports of both halves on their vertices, (12,) DOFs (``support_321``)."""
    vertices = np.arange(mesh.p.shape[1])
    return np.concatenate([support_321(coordinates, vertices[halves[vertices] == half]) for half in (0, 1)])


def patch_groups(n_patches: int) -> tuple[int, ...]:
    """Mirror-symmetry groups of patches in a row: patches p and n - 1 - p share joint parameters,
    (0, 1, 2, 1, 0) for five (paper Fig. 4)."""
    return tuple(min(p, n_patches - 1 - p) for p in range(n_patches))


@dataclass(frozen=True)
class BeamReduction:
    """The Hurty/Craig-Bampton reduction of one beam and its patch layout.

    hcb: the reduction (basis over the full DOFs, reduced M and K); references: (n_patches, 3) m, the virtual-node
    positions (patch centroids, shared by lower and upper patches); patch_areas: (n_patches,) m^2 of the lower
    patches (the upper ones are their copies); patch_second_moments: (n_patches, 2, 2) m^4 of the lower patches
    about the virtual nodes (``geometry.properties.face_second_moments``); constraints: T (6 n_virtual, n_dof);
    halves: (n_nodes,) 0/1.
    """

    hcb: HurtyCraigBampton
    references: np.ndarray
    patch_areas: np.ndarray
    patch_second_moments: np.ndarray
    constraints: sp.csr_matrix
    halves: np.ndarray


def reduce_beam(mesh: MeshTet, beam_mesh: BeamMesh, stiffness: sp.spmatrix, mass: sp.spmatrix,
                n_modes: int = N_FIXED_INTERFACE_MODES, method: str | None = None) -> BeamReduction:
    """Whole-joint patches and the Hurty/Craig-Bampton reduction of the two unjoined halves.

    mesh: the solid mesh (``fem.elasticity.solid_mesh``) of ``beam_mesh``; stiffness (N/m), mass (kg): (n_dof,
    n_dof) of both halves, without anything joining them. Raises PatchLayoutError for mismatched patches and
    ``fem.coupling.CouplingError`` for a patch whose nodes cannot define a rigid motion.
    """
    n_patches = check_patch_layout(beam_mesh)
    references, lower, upper = patch_couplings(mesh, beam_mesh)
    constraints = boundary_constraints(lower, upper)
    coordinates = quadratic_node_coordinates(mesh)
    halves = quadratic_node_halves(mesh, beam_mesh)
    hcb = hurty_craig_bampton(stiffness, mass, constraints, half_rigid_modes(coordinates, halves),
                              half_supports(coordinates, mesh, halves), n_modes, method)
    faces = [beam_mesh.faces[f"lower_patch_{p}"] for p in range(1, n_patches + 1)]
    areas = np.array([triangle_areas(beam_mesh.points, face).sum() for face in faces])
    second_moments = np.array([face_second_moments(beam_mesh.points, face, reference)
                               for face, reference in zip(faces, references)])
    return BeamReduction(hcb, references, areas, second_moments, constraints, halves)


def bolt_string_stiffness(mesh: MeshTet, beam_mesh: BeamMesh, beam: BeamParameters, bolt: Bolt) -> sp.csr_matrix:
    """Stress stiffness of the preloaded shanks (taut strings between the washer reference points, H apart),
    (n_dof, n_dof) N/m, as in ``fem.prestress``: the part of the FE stage's K_sigma that belongs to the bolts."""
    return assemble_shanks(washer_couplings(mesh, beam_mesh, beam), shank_stress_stiffness(bolt.preload, beam.height))


def preload_vector(mesh: MeshTet, beam_mesh: BeamMesh, beam: BeamParameters, bolt: Bolt,
                   basis: np.ndarray) -> np.ndarray:
    """Generalised force of the bolt pretension (``fem.bolts.preload_forces``) on the reduced coordinates, (n,) N."""
    return basis.T @ preload_forces(washer_couplings(mesh, beam_mesh, beam), bolt)


def whole_joint_superelement(reduction: BeamReduction, stiffness: np.ndarray, sensors: np.ndarray,
                             preload: np.ndarray | None, name: str) -> Superelement:
    """The nonlinear stage's ``Superelement`` of a beam reduction: patch_motion the relative (upper minus lower)
    virtual-node motion, mirror-symmetric patch groups, sensor rows (n_sensors, n) m, the patches' second moments
    of area (the joint's normal springs act on the patch rotations through them).

    stiffness: the reduced stiffness to use (``reduction.hcb.stiffness``, or K_A reduced), (n, n) N/m.
    """
    n_patches, n_reduced = len(reduction.patch_areas), reduction.hcb.mass.shape[0]
    return Superelement(mass=reduction.hcb.mass, stiffness=stiffness,
                        patch_motion=relative_patch_motion(n_patches, n_reduced),
                        patch_areas=reduction.patch_areas, patch_groups=patch_groups(n_patches), sensors=sensors,
                        preload=preload, name=name, patch_second_moments=reduction.patch_second_moments)

