"""The prestressed superelements with the joint's normal springs acting on the patch rotations.

Physics checked, against hand calculations on rigid halves and a dense eigen-solve:
- the patches' second moments of area measured on the mesh equal the strips' less their holes (exact for the
  patches without a hole; polygonal holes for the others);
- the tied prestressed model is positive definite once the patch rotations are tied with the translations,
  while tying the translations alone leaves the relative twist about the line of patch centres unstable;
- the twist frequency with the normal springs spread over the patches (rotational stiffness K_z J / A) equals
  the rigid-halves value sqrt((sum K_z J_xx / A - 3 P H / 4) / I_rel) / 2 pi: the prestress's -3 P H / 4 is the
  halves' geometric stiffness (-3 P H / 2 each) plus the bolt strings (+P H (theta_1 + theta_2)^2 / 4 per bolt)
  for a relative rotation theta_1 = -theta_2 (docs/design.md section 4);
- a joint whose normal springs are too soft to carry that softening is flagged unstable, with the count of
  negative stuck modes a dense eigen-solve finds, and kept in the results with its reason.
"""

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg

from fem.bolts import BOLT_PRELOAD
from geometry.parameters import BEAM_NAMES, BEAMS
from geometry.properties import patch_areas, patch_second_moments
from nonlinear.condensation import RIGID_FREQUENCY, joint_space, stuck_stiffness_matrix, stuck_modes
from nonlinear.joint import patch_elements, random_designs, stuck_stiffness
from nonlinear.qsma_vectorised import UNSTABLE, qsma_designs
from reduction.superelement import (StructureError, beam_superelement, rigid_reduced_coordinates, save_superelement,
                                   stuck_joint_modes)

NEGATIVE = -(2 * np.pi * RIGID_FREQUENCY) ** 2  # rad^2/s^2: below it a mode has negative stiffness
STIFF_TANGENTIAL = 1e9  # N/m


@pytest.fixture(scope="module")
def superelements(beam_roms):
    return {(beam, prestress): beam_superelement(beam_roms / f"{beam}.npz", prestress)
            for beam in BEAM_NAMES for prestress in (True, False)}


def tied_eigenvalues(superelement, joint_map):
    """Eigenvalues (rad^2/s^2) of the superelement with the rows of ``joint_map`` held at zero."""
    eigenvalues, modes = scipy.linalg.eigh(superelement.stiffness, superelement.mass)
    null_basis = scipy.linalg.null_space(joint_map @ modes)
    return np.linalg.eigvalsh(null_basis.T @ (eigenvalues[:, None] * null_basis))


def twist_stiffness_per_normal_stiffness(beam):
    """sum_p J_xx,p / A_p (m^2) of the beam's patches, from the analytic strips: the relative twist stiffness per
    unit normal stiffness K_z of every patch."""
    return float(np.sum(patch_second_moments(BEAMS[beam])[:, 0, 0] / patch_areas(BEAMS[beam])))


def prestress_twist_softening(beam):
    """3 P H / 4 (N m/rad), the clamp's geometric softening of the relative twist of rigid halves."""
    return 3 * BOLT_PRELOAD * BEAMS[beam].height / 4


def uniform_joint(normal_stiffness, n_patches=5):
    """Stuck tangents (3 n_patches,) N/m: stiff tangential springs, the same K_z on every patch."""
    return np.tile([STIFF_TANGENTIAL, STIFF_TANGENTIAL, normal_stiffness], n_patches)


@pytest.mark.parametrize("beam", BEAM_NAMES)
def test_patch_second_moments_measured_on_the_mesh_equal_the_strips_less_their_holes(superelements, beam):
    measured = superelements[beam, True].patch_second_moments
    analytic = patch_second_moments(BEAMS[beam])
    holes = np.array([any(lower < x < upper for x in BEAMS[beam].bolt_x) for lower, upper in BEAMS[beam].patch_bounds])
    diagonal = (slice(None), [0, 1], [0, 1])
    np.testing.assert_allclose(measured[~holes][diagonal], analytic[~holes][diagonal], rtol=1e-9)
    # a polygon inscribed in the hole (the straight-sided mesh) removes a little less than the circle
    np.testing.assert_allclose(measured[holes][diagonal], analytic[holes][diagonal], rtol=1e-3)
    assert np.all(np.abs(measured[:, 0, 1]) < 1e-9 * measured[:, 0, 0])  # mirror symmetry about y = 0


@pytest.mark.parametrize("beam", BEAM_NAMES)
def test_tied_prestressed_model_is_definite_only_with_the_patch_rotations_tied(superelements, beam):
    stressed, unstressed = superelements[beam, True], superelements[beam, False]
    translations_only = tied_eigenvalues(stressed, stressed.relative_translation)
    twist = translations_only[translations_only < NEGATIVE]
    assert len(twist) == 1  # the relative twist about the line of patch centres
    # its rigid-halves value: -3 P H / 4 on the relative angle over I_rel about the patch line (not exact: the
    # halves twist elastically too, and their own torsion stiffens nothing when nothing holds them)
    assert -np.sqrt(-twist[0]) / (2 * np.pi) < -150.0
    assert np.all(tied_eigenvalues(stressed, stressed.joint_motion) > NEGATIVE)
    # stress stiffening moves the tied first bending by less than 1e-4 (docs/benchmarks.md)
    stressed_hz, unstressed_hz = (stuck_joint_modes(s, 1)[0][0] for s in (stressed, unstressed))
    assert abs(stressed_hz / unstressed_hz - 1) < 1e-4


def half_rotation_about_patch_line(superelement, half):
    """Reduced coordinates (n,) of a unit rigid rotation about x of one half (0 lower, 1 upper): every patch
    centre lies on the x axis, so its virtual nodes rotate without translating; the modal coordinates stay zero
    (the constraint modes reproduce rigid motions exactly)."""
    rotation = np.zeros(superelement.mass.shape[0])
    first = half * 6 * superelement.n_patches
    rotation[first + 3:first + 6 * superelement.n_patches:6] = 1.0
    return rotation


def rigid_halves_twist_hz(superelement, beam, normal_stiffness, prestress):
    """Hand calculation: sqrt((K_z sum J_xx / A - 3 P H / 4) / I_rel) / 2 pi with I_rel = I_x / 2, I_x the
    rotary inertia of one half about the line of patch centres."""
    lower = half_rotation_about_patch_line(superelement, 0)
    stiffness = normal_stiffness * twist_stiffness_per_normal_stiffness(beam)
    stiffness -= prestress_twist_softening(beam) if prestress else 0.0
    return np.sqrt(stiffness / (lower @ superelement.mass @ lower / 2)) / (2 * np.pi)


def twist_mode_hz(superelement, normal_stiffness):
    """Frequency (Hz) of the stuck mode most like the relative rigid twist of the halves about the patch line,
    from a dense eigen-solve of the condensed stuck structure."""
    space = joint_space(superelement)
    eigenvalues, shapes = np.linalg.eigh(stuck_stiffness_matrix(space, uniform_joint(normal_stiffness)))
    twist = half_rotation_about_patch_line(superelement, 0) - half_rotation_about_patch_line(superelement, 1)
    modal = space.modes.T @ superelement.mass @ twist
    mac = (shapes.T @ modal) ** 2 / (modal @ modal)
    target = int(np.argmax(mac))
    assert mac[target] > 0.9
    return np.sqrt(eigenvalues[target]) / (2 * np.pi)


@pytest.mark.parametrize(("prestress", "normal_stiffness", "tolerance"), [(False, 1e5, 0.01), (True, 3e6, 0.02)])
def test_twist_frequency_matches_rigid_halves_on_the_spread_normal_springs(superelements, prestress,
                                                                          normal_stiffness, tolerance):
    """The tolerance is the rigid-halves model's own error: the halves' flexibility and the offset of their
    centres of mass from the patch line (0.5 % at 84 Hz, 1 % at 390 Hz, where the halves' first elastic modes lie
    near 600 Hz)."""
    superelement = superelements["BRB", prestress]
    exact = twist_mode_hz(superelement, normal_stiffness)
    hand = rigid_halves_twist_hz(superelement, "BRB", normal_stiffness, prestress)
    assert exact == pytest.approx(hand, rel=tolerance)


@pytest.mark.parametrize("beam", BEAM_NAMES)
def test_joint_too_soft_for_the_preload_is_flagged_unstable(superelements, beam):
    """The rigid-halves threshold K_z* = (3 P H / 4) / sum (J_xx / A): a fifth below it the twist is unstable,
    a quarter above it every stuck mode is stable (the halves' flexibility moves the threshold by far less)."""
    space = joint_space(superelements[beam, True])
    threshold = prestress_twist_softening(beam) / twist_stiffness_per_normal_stiffness(beam)
    modes = stuck_modes(space, np.array([uniform_joint(0.8 * threshold), uniform_joint(1.25 * threshold)]))
    assert modes.unstable.tolist() == [1, 0]
    assert modes.found.tolist() == [False, True]
    unstressed = stuck_modes(joint_space(superelements[beam, False]), uniform_joint(0.8 * threshold)[None])
    assert unstressed.unstable.tolist() == [0]


def test_unstable_designs_are_counted_as_a_dense_solve_counts_them_and_kept(superelements):
    superelement = superelements["SBRB", True]
    space = joint_space(superelement)
    designs = random_designs("iwan4", 300, 3, np.random.default_rng(7))
    stiffness = stuck_stiffness(patch_elements("iwan4", designs, superelement.patch_groups))
    dense = np.array([np.count_nonzero(np.linalg.eigvalsh(stuck_stiffness_matrix(space, k)) < NEGATIVE)
                      for k in stiffness])
    counted = stuck_modes(space, stiffness).unstable
    np.testing.assert_array_equal(counted, dense)
    assert 0 < np.count_nonzero(dense) < len(designs)
    result = qsma_designs(space, "iwan4", designs, amplitudes=np.geomspace(1e-7, 1e-5, 3))
    assert result.frequency.shape[0] == len(designs)
    flagged = np.all(result.reason == UNSTABLE, axis=1)
    np.testing.assert_array_equal(flagged, dense > 0)
    assert np.all(np.isnan(result.stuck_frequency[flagged])) and not np.any(result.converged[flagged])


def test_superelement_of_an_older_reduction_stage_is_refused(superelements, tmp_path):
    """Without the patches' second moments the joint would silently lose its rotational rows."""
    save_superelement(replace(superelements["BRB", False], patch_second_moments=None), tmp_path / "BRB.npz")
    with pytest.raises(StructureError, match="patch_second_moments.*rerun `make rom`"):
        beam_superelement(tmp_path / "BRB.npz")


@pytest.mark.parametrize("beam", BEAM_NAMES)
def test_prestressed_assembly_moves_rigidly_without_force(superelements, beam_roms, beam):
    """The clamp's prestress is self-equilibrated, so a rigid motion R of the whole assembly carries no force:
    K R = 0 to round-off for the balanced K_A + K_bolt (2e-15 to 4e-15 of |K| |R|; the stored sum leaves 2.8e-6 on
    the rotations about x and y, ``reduction.superelement.balanced_stiffness``)."""
    superelement = superelements[beam, True]
    with np.load(beam_roms / f"{beam}.npz", allow_pickle=False) as data:
        rigid = rigid_reduced_coordinates(data["virtual_node_coordinates"][:superelement.n_patches],
                                          superelement.mass.shape[0])
        stored = data["stiffness_prestressed"] + data["bolt_stress_stiffness"]
    scale = np.abs(superelement.stiffness).max() * np.abs(rigid).max()
    assert np.abs(superelement.stiffness @ rigid).max() <= 1e-12 * scale
    assert np.abs(stored @ rigid).max() > 1e-7 * scale
