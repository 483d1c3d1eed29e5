"""The Hurty/Craig-Bampton superelement of the three beams with whole-joint patches (docs/design.md section 4),
coarse meshes (about 40 s: per beam, assembly, reduction and two full-model eigen-solves); default meshes in a
slow test."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg

from conftest import COARSE
from fem.bolts import Bolt, bolts_mass, quadratic_triangles, washer_couplings
from fem.coupling import CouplingError, nodal_areas
from fem.elasticity import (Material, mass_matrix, quadratic_node_coordinates, rigid_body_modes, solid_mesh,
                            stiffness_matrix)
from fem.solver import natural_modes
from fem.springs import joint_stiffness, patch_couplings
from geometry.beam_mesh import read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BEAMS, MeshParameters
from reduction.craig_bampton import (PatchLayoutError, boundary_constraints, half_rigid_modes,
                                     relative_patch_motion, rigid_body_properties)
from reduction.sensors import INSIDE, accelerometer_points, point_recovery, top_face_height
from reduction.superelement import rigid_reduced_coordinates, stuck_joint_modes, virtual_rigid_motion
from reduction.whole_joint import reduce_beam

ARM = 0.01  # m: rotational springs k ARM^2, a patch-sized lever on the translational stiffness (test_fem_springs)
BENDING_TOLERANCE = 5e-3  # the acceptance: first four bending frequencies within 0.5 %


def springs(translational: float, rotational_arm: float = ARM) -> np.ndarray:
    return np.array([translational] * 3 + [translational * rotational_arm ** 2] * 3)


def beam_model(name: str, beam_mesh):
    """Solid K, M with the bolt masses, and the superelement of the two halves."""
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    stiffness = stiffness_matrix(mesh, Material())
    mass = (mass_matrix(mesh, Material()) + bolts_mass(washer_couplings(mesh, beam_mesh, BEAMS[name]), Bolt())).tocsr()
    return mesh, stiffness, mass, reduce_beam(mesh, beam_mesh, stiffness, mass)


@pytest.fixture(scope="module")
def brb(coarse_brb):
    return ("BRB", coarse_brb) + beam_model("BRB", coarse_brb)


@pytest.fixture(scope="module", params=list(BEAMS))
def beam(request, tmp_path_factory):
    if request.param == "BRB":
        return request.getfixturevalue("brb")
    sidecar = make_beam(BEAMS[request.param], COARSE, tmp_path_factory.mktemp(request.param), render=False)
    beam_mesh = read_beam_mesh(sidecar.with_suffix(".msh"))
    return (request.param, beam_mesh) + beam_model(request.param, beam_mesh)


def reduced_frequencies(reduction, spring: np.ndarray) -> np.ndarray:
    """Frequencies (Hz) of the superelement with the same springs on every patch pair's relative motion."""
    hcb = reduction.hcb
    relative = relative_patch_motion(len(reduction.patch_areas), hcb.mass.shape[0])
    joint = relative.T @ np.diag(np.tile(spring, len(reduction.patch_areas))) @ relative
    eigenvalues = scipy.linalg.eigh(hcb.stiffness + joint, hcb.mass, eigvals_only=True)
    return np.sign(eigenvalues) * np.sqrt(np.abs(eigenvalues)) / (2 * np.pi)


def out_of_plane(shapes: np.ndarray) -> np.ndarray:
    """Whether each mode (columns of (n_dof, k)) moves mostly normal to the lap (z): the bending studied here."""
    components = np.linalg.norm(shapes.reshape(-1, 3, shapes.shape[1]), axis=0)
    return components[2] > components[:2].max(axis=0)


def test_rigid_motion_of_each_half_is_reproduced_exactly_by_its_virtual_nodes(brb):
    """Virtual nodes moved as a rigid motion of one half (t + theta x c_p, theta at each centroid c_p) expand to
    exactly that rigid motion of the half, the other half at rest: 1e-12 relative, the round-off of the coupling
    (test_coupling) and of the saddle-point solve."""
    _, beam_mesh, mesh, _, _, reduction = brb
    coordinates = quadratic_node_coordinates(mesh)
    rigid = half_rigid_modes(coordinates, reduction.halves)
    virtual = virtual_rigid_motion(reduction.references)  # (30, 6): one side's five virtual nodes
    n_reduced = reduction.hcb.basis.shape[1]
    for half in (0, 1):
        reduced = np.zeros((n_reduced, 6))
        reduced[30 * half:30 * (half + 1)] = virtual
        expanded = reduction.hcb.basis @ reduced
        columns = rigid[:, 6 * half:6 * (half + 1)]
        assert np.abs(expanded - columns).max() < 1e-12 * np.abs(columns).max()


def test_patch_tractions_map_to_the_virtual_node_force_and_moment(brb):
    """Nodal forces f_i = w_i (F / A + beta x r_i) on one patch (w_i its nodal areas, r_i = x_i - c) are a uniform
    traction F / A plus a linear one of moment J beta about the centroid. Through the reduction they act on that
    patch's virtual node only, as force F and moment J beta (J = sum w_i (|r_i|^2 I - r_i r_i^T)), and on no modal
    coordinate: the coupling weights are the consistent loads of a traction (1e-12 relative)."""
    _, beam_mesh, mesh, _, _, reduction = brb
    coordinates = quadratic_node_coordinates(mesh)
    rng = np.random.default_rng(3)
    for side, patch in (("lower", 1), ("upper", 3)):
        weights = nodal_areas(coordinates, quadratic_triangles(mesh, beam_mesh.faces[f"{side}_patch_{patch}"]))
        nodes = np.flatnonzero(weights)
        area, arm = weights.sum(), coordinates[nodes] - reduction.references[patch - 1]
        inertia = (np.einsum("i,ij,ij->", weights[nodes], arm, arm) * np.eye(3)
                   - np.einsum("i,ij,ik->jk", weights[nodes], arm, arm))
        force = rng.normal(size=3) * 100.0  # N; and a moment of about 100 N m:
        beta = rng.normal(size=3) * 100.0 / np.linalg.norm(inertia, 2)
        loads = np.zeros_like(coordinates)
        loads[nodes] = weights[nodes, None] * (force / area + np.cross(beta, arm))
        generalised = reduction.hcb.basis.T @ loads.ravel()
        expected = np.zeros_like(generalised)
        first = 30 * (side == "upper") + 6 * (patch - 1)
        expected[first:first + 6] = np.concatenate([force, inertia @ beta])
        scale = np.abs(expected).max()
        assert np.abs(generalised - expected).max() < 1e-12 * scale


def test_superelement_with_springs_matches_the_full_model(beam):
    """Same linear springs (k = 1e9 N/m, k ARM^2 N m/rad) on the patch pairs of the full FE model (fem.springs) and
    of the superelement: every elastic frequency up to the fourth out-of-plane bending mode within 0.5 %
    (measured: below 7e-5 for the first four bending modes of each beam)."""
    name, beam_mesh, mesh, stiffness, mass, reduction = beam
    _, lower, upper = patch_couplings(mesh, beam_mesh)
    spring = springs(1e9)
    full, shapes = natural_modes(stiffness + joint_stiffness(lower, upper, spring), mass, 20)
    bending = np.flatnonzero(out_of_plane(shapes[:, 6:]))
    assert len(bending) >= 4, f"{name}: fewer than four out-of-plane bending modes among the first 14"
    compared = slice(6, 6 + bending[3] + 1)
    reduced = reduced_frequencies(reduction, spring)
    assert np.all(np.abs(reduced[compared] / full[compared] - 1) < BENDING_TOLERANCE)
    assert np.all(reduced[compared] >= full[compared] * (1 - 1e-9))  # a Ritz reduction can only stiffen


def test_zero_energy_modes_twelve_free_seven_translational_six_with_rotational_springs(beam):
    """Two free halves: 12; translational springs only: 7 (all patch centroids on the x axis leave the relative
    twist about x free); with rotational springs too: the joined beam's 6. Zero: below 1 Hz (the rigid threshold
    of nonlinear.condensation): the dense solve's round-off, eps times the largest eigenvalue, leaves them near
    0.01 Hz, and the first elastic mode lies above 60 Hz."""
    _, _, _, _, _, reduction = beam
    for spring, expected in ((springs(0.0), 12), (springs(1e9, 0.0), 7), (springs(1e9), 6)):
        frequencies = reduced_frequencies(reduction, spring)
        assert np.count_nonzero(np.abs(frequencies) < 1.0) == expected
        assert frequencies[expected] > 60.0


def test_mass_centre_and_inertia_equal_the_full_model(beam):
    """The reduced mass of the rigid motions of the whole beam equals the full model's (relative 1e-12): total
    mass, centre of mass and rotational inertia about it. The mass includes the 3 x 28.64 g of bolts."""
    _, _, mesh, _, mass, reduction = beam
    rigid = rigid_body_modes(quadratic_node_coordinates(mesh), centre=np.zeros(3))
    reduced = rigid_reduced_coordinates(reduction.references, reduction.hcb.basis.shape[1])
    full = rigid_body_properties(rigid.T @ mass @ rigid)
    superelement = rigid_body_properties(reduced.T @ reduction.hcb.mass @ reduced)
    assert superelement[0] == pytest.approx(full[0], rel=1e-12)
    assert np.abs(superelement[1] - full[1]).max() < 1e-12 * np.ptp(mesh.p[0])
    assert np.abs(superelement[2] - full[2]).max() < 1e-12 * np.abs(full[2]).max()
    assert full[0] > 3 * Bolt().mass


def test_accelerometers_sit_on_the_top_face_and_recover_quadratic_fields_exactly(beam):
    """The ten sensor points lie inside the mesh just below the top face (on the SBRB's flexures, two of them, the
    flexure's face), and the recovery interpolates any quadratic displacement field exactly (round-off, 1e-15 m)."""
    name, _, mesh, _, _, _ = beam
    points = accelerometer_points(BEAMS[name])
    assert np.all(np.abs(points[:, 2] - top_face_height(BEAMS[name], points[:, 0])) <= 2 * INSIDE)
    assert np.count_nonzero(points[:, 2] < BEAMS[name].height / 2 - INSIDE - 1e-12) == (2 if name == "SBRB" else 0)
    coordinates = quadratic_node_coordinates(mesh)
    field = np.column_stack([coordinates[:, 0] ** 2, coordinates[:, 1] * coordinates[:, 2], coordinates[:, 2]])
    expected = np.column_stack([points[:, 0] ** 2, points[:, 1] * points[:, 2], points[:, 2]])
    assert np.abs(point_recovery(mesh, points) @ field.ravel() - expected.ravel()).max() < 1e-15


def test_rigid_body_properties_of_a_point_mass():
    """A point mass m at c: mass m, centre c, no inertia about its own centre."""
    point = np.array([[0.3, -0.2, 0.1]])
    rigid = rigid_body_modes(point, centre=np.zeros(3))
    total, centre, inertia = rigid_body_properties(2.5 * rigid.T @ rigid)
    assert total == pytest.approx(2.5) and np.allclose(centre, point[0]) and np.allclose(inertia, 0.0, atol=1e-15)


def test_a_patch_without_nodes_or_unpaired_patches_give_clear_errors(coarse_brb):
    mesh = solid_mesh(coarse_brb.points, coarse_brb.tetrahedra)
    empty = dataclasses.replace(coarse_brb, faces={**coarse_brb.faces,
                                                    "lower_patch_2": coarse_brb.faces["lower_patch_2"][:0]})
    with pytest.raises(CouplingError, match="lower_patch_2: 0 weighted node"):
        reduce_beam(mesh, empty, None, None)
    unpaired = dataclasses.replace(coarse_brb, faces={name: faces for name, faces in coarse_brb.faces.items()
                                                      if name != "upper_patch_5"})
    with pytest.raises(PatchLayoutError, match=r"lower patches \[1, 2, 3, 4, 5\] and upper patches \[1, 2, 3, 4\]"):
        reduce_beam(mesh, unpaired, None, None)
    _, lower, upper = patch_couplings(mesh, coarse_brb)
    with pytest.raises(PatchLayoutError, match="5 lower patches .* 4 upper patches"):
        boundary_constraints(lower, upper[:24])


ASB_CONFIGURATIONS = ["C1", "C2", "C3", "C4", "C4a", "CD1"]


@pytest.mark.parametrize("configuration", ASB_CONFIGURATIONS)
def test_asb_models_first_flexible_mode_with_the_joint_stuck(configuration, asb_superelement):
    """The external ASB superelements run through the same code: their first flexible mode with every relative
    patch translation held lies between 60 and 300 Hz (an assembly of two 25 mm plates; measured first modes
    94 to 298 Hz, data/README.md). Reported frequencies: see the README."""
    superelement = asb_superelement(configuration)
    frequencies, shapes = stuck_joint_modes(superelement)
    print(f"{configuration}: first flexible mode with the joint stuck {frequencies[0]:.2f} Hz")
    assert 60.0 < frequencies[0] < 300.0
    joint = superelement.relative_translation
    assert np.abs(joint @ shapes[:, 0]).max() < 1e-12 * np.abs(joint).max() * np.abs(shapes[:, 0]).max()


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BEAMS))
def test_superelement_matches_the_full_model_on_the_default_mesh(name, tmp_path):
    """As the coarse test, on the default meshes (BRB 130k DOF; with the QSMA oracle checks, 4.5 minutes in all
    on a clean clone here). Measured largest error up to the fourth out-of-plane bending mode: 5.6e-4 (BRB)."""
    sidecar = make_beam(BEAMS[name], MeshParameters(), tmp_path, render=False)
    beam_mesh = read_beam_mesh(sidecar.with_suffix(".msh"))
    mesh, stiffness, mass, reduction = beam_model(name, beam_mesh)
    _, lower, upper = patch_couplings(mesh, beam_mesh)
    full, shapes = natural_modes(stiffness + joint_stiffness(lower, upper, springs(1e9)), mass, 20)
    bending = np.flatnonzero(out_of_plane(shapes[:, 6:]))
    compared = slice(6, 6 + bending[3] + 1)
    reduced = reduced_frequencies(reduction, springs(1e9))
    print(name, np.column_stack([full[compared], reduced[compared]]))
    assert np.all(np.abs(reduced[compared] / full[compared] - 1) < BENDING_TOLERANCE)
