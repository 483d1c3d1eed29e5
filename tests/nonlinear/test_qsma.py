"""QSMA reference implementation: exact on an analytic model, linear at low amplitude, shape-tracked mode,
and the same backbone under amplitude and force control.
"""

import numpy as np
import pytest
import scipy.linalg

from nonlinear import iwan, jenkins
from nonlinear.condensation import UNAMBIGUOUS_MAC, joint_space, stuck_stiffness_matrix
from nonlinear.joint import BRB_PATCH_GROUPS, parameter_names, patch_elements, random_designs, stuck_stiffness
from nonlinear.parameters import FrictionParameterError
from nonlinear.qsma import qsma_reference
from reduction.superelement import Superelement

LOWER_MASS, UPPER_MASS_X, UPPER_MASS_Y = 2.0, 3.0, 5.0  # kg


def two_body_superelement():
    """Two rigid bodies joined by one patch: point masses free in x, y, z (the upper one with a different
    effective mass in y, so that the x and y joint modes have distinct frequencies). Stuck, the x mode has
    omega^2 = K_T / mu with mu = m1 m2x / (m1 + m2x); its relative motion is r = q / sqrt(mu)."""
    mass = np.diag([LOWER_MASS] * 3 + [UPPER_MASS_X, UPPER_MASS_Y, 4.0])
    patch_motion = np.zeros((6, 6))
    patch_motion[:3, :3], patch_motion[:3, 3:] = -np.eye(3), np.eye(3)
    return Superelement(mass=mass, stiffness=np.zeros((6, 6)), patch_motion=patch_motion,
                        patch_areas=np.array([1e-3]), patch_groups=(0,), sensors=np.eye(6), name="two bodies")


def two_body_space():
    x_mode = np.array([-UPPER_MASS_X, 0, 0, LOWER_MASS, 0, 0])
    return joint_space(two_body_superelement(), reference_mode=x_mode)


REDUCED_MASS = LOWER_MASS * UPPER_MASS_X / (LOWER_MASS + UPPER_MASS_X)
TWO_BODY_CASES = [
    ("jenkins", [300.0, 2.0e6, 1.0e7],
     lambda u: jenkins.backbone(u, 2.0e6, 300.0), lambda u: jenkins.dissipation(u, 2.0e6, 300.0)),
    ("iwan4", [300.0, 2.0e6, -0.4, 0.2, 1.0e7],
     lambda u: iwan.four_parameter_backbone(u, 300.0, 2.0e6, -0.4, 0.2),
     lambda u: iwan.four_parameter_dissipation(u, 300.0, 2.0e6, -0.4, 0.2)),
    ("iwan5", [300.0, 2.0e6, -0.7, 3.0, 0.8, 1.0e7],
     lambda u: iwan.five_parameter_backbone(u, 300.0, 2.0e6, -0.7, 3.0, 0.8),
     lambda u: iwan.five_parameter_dissipation(u, 300.0, 2.0e6, -0.7, 3.0, 0.8)),
]


@pytest.mark.parametrize("model, design, backbone, dissipation", TWO_BODY_CASES)
def test_two_body_backbone_is_the_element_backbone(model, design, backbone, dissipation):
    """One relative DOF: omega^2 = f(r) / (mu r), zeta = D(r) / (2 pi r f(r)) + zeta_0, r = q / sqrt(mu),
    from micro- to macroslip (slip displacement 1.5e-4 m)."""
    slip = 300.0 / 2.0e6
    r = slip * np.logspace(-3, np.log10(0.9), 12)
    q = np.sqrt(REDUCED_MASS) * r
    result = qsma_reference(two_body_space(), model, design, amplitudes=q, linear_damping=1e-3)
    assert result.converged.all()
    np.testing.assert_allclose(result.frequency, np.sqrt(backbone(r) / (REDUCED_MASS * r)), rtol=1e-9)
    np.testing.assert_allclose(result.damping, dissipation(r) / (2 * np.pi * r * backbone(r)) + 1e-3, rtol=1e-8)
    np.testing.assert_allclose(result.stuck_frequency, np.sqrt(2.0e6 / REDUCED_MASS), rtol=1e-12)
    np.testing.assert_allclose(result.joint_displacement[:, 1], 0.0, atol=1e-12 * slip)  # y is not excited


def plain_stuck_frequencies(superelement, design, model):
    """Eigenfrequencies (rad/s) of (K + B^T K_d B, M) by a plain generalised solve: accurate for moderate
    joint stiffnesses, the independent reference for the low-amplitude limit."""
    joint = superelement.relative_translation
    k = stuck_stiffness(patch_elements(model, design, superelement.patch_groups))[0]
    eigenvalues = scipy.linalg.eigh(superelement.stiffness + joint.T @ (k[:, None] * joint), superelement.mass,
                                    eigvals_only=True)
    return np.sqrt(np.abs(eigenvalues))


@pytest.mark.parametrize("configuration", ["C1", "CD1"])
@pytest.mark.parametrize("model, design_per_group, slip_scale", [
    ("jenkins", [2.0e3, 3.0e8, 1.0e9], 1e-3),      # stuck below slip: exactly linear
    ("iwan4", [2.0e3, 3.0e8, -0.1, 0.5, 1.0e9], 1e-8),  # microslip softening ~ x^(chi+1) = 1e-7.2
])
def test_low_amplitude_limit_is_the_stuck_linear_mode(configuration, model, design_per_group, slip_scale,
                                                     asb_superelement):
    superelement = asb_superelement(configuration)
    n_groups = max(superelement.patch_groups) + 1
    design = np.tile(design_per_group, n_groups)
    q = slip_scale * 2.0e3 / 3.0e8 * np.array([0.1, 1.0])  # modal amplitude per unit joint motion ~ 1
    result = qsma_reference(joint_space(superelement), model, design, amplitudes=q)
    assert result.converged.all()
    plain = plain_stuck_frequencies(superelement, design, model)
    nearest = plain[np.argmin(np.abs(plain - result.stuck_frequency))]
    assert result.stuck_frequency == pytest.approx(nearest, rel=1e-6)
    np.testing.assert_allclose(result.frequency, result.stuck_frequency, rtol=1e-6)
    assert result.mac > UNAMBIGUOUS_MAC


@pytest.mark.parametrize("configuration, beam_like", [("C1", False), ("CD1", True)])
def test_tracked_mode_is_the_bending_mode_even_above_rocking_modes(configuration, beam_like, asb_superelement):
    """1000 Table 3 designs. The mode tracked by shape is unambiguous (MAC > 0.5: no other mode can match the
    reference) except for rare veering pairs, and in some designs it is not the first stuck mode, so
    selection by index would be wrong. On the beam-like CD1 (five patches in a row), designs whose first
    mode is a rigid rocking of the halves on soft joint springs (under 5 % of its energy in the halves)
    track an elastic bending mode (over half of its energy in the halves). On the square-lap C1 the bending
    mode itself is a rotation at the joint, carried mostly by the joint springs when they are soft."""
    superelement = asb_superelement(configuration)
    space = joint_space(superelement)
    designs = random_designs("iwan4", 1000, max(superelement.patch_groups) + 1, np.random.default_rng(6))
    k = stuck_stiffness(patch_elements("iwan4", designs, superelement.patch_groups))
    eigenvalues, shapes = np.linalg.eigh(stuck_stiffness_matrix(space, k))
    mac = (np.einsum("dmk,m->dk", shapes, space.reference)) ** 2
    tracked = np.argmax(mac, axis=1)
    assert np.mean(mac.max(axis=1) > UNAMBIGUOUS_MAC) > 0.99
    elastic_share = np.einsum("m,dmk->dk", space.eigenvalues, shapes ** 2) / eigenvalues
    assert np.mean(tracked > 0) > 0.01
    if not beam_like:
        return
    rocking_first = (tracked > 0) & (elastic_share[:, 0] < 0.05)
    assert rocking_first.sum() >= 4
    tracked_share = elastic_share[np.arange(len(designs)), tracked]
    assert np.all(tracked_share[rocking_first] > 0.5)
    for design in designs[rocking_first][:3]:
        result = qsma_reference(space, "iwan4", design, amplitudes=[1e-9])
        assert result.mac > UNAMBIGUOUS_MAC and result.stuck_frequency > np.sqrt(eigenvalues[rocking_first, 0].max())


@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan5"])
def test_amplitude_and_force_control_give_the_same_backbone(model, asb_superelement):
    superelement = asb_superelement("CD1")
    space = joint_space(superelement)
    design = {"jenkins": [200.0, 1e8, 1e9, 500.0, 3e8, 1e10, 800.0, 1e9, 1e9],
              "iwan4": [200.0, 1e8, -0.3, 0.1, 1e9, 500.0, 3e8, -0.6, 1.0, 1e10, 800.0, 1e9, -0.8, 0.01, 1e9],
              "iwan5": [200.0, 1e8, -0.3, 0.1, 0.9, 1e9, 500.0, 3e8, -0.6, 1.0, 0.7, 1e10,
                        800.0, 1e9, -0.8, 0.01, 0.95, 1e9]}[model]
    amplitudes = np.logspace(-7, -4, 10)
    by_amplitude = qsma_reference(space, model, design, amplitudes=amplitudes, linear_damping=1e-3)
    usable = by_amplitude.converged
    by_force = qsma_reference(space, model, design, forces=by_amplitude.force[usable], linear_damping=1e-3)
    assert usable.sum() >= 8 and by_force.converged.all()
    np.testing.assert_allclose(by_force.amplitude, amplitudes[usable], rtol=1e-8)
    np.testing.assert_allclose(by_force.frequency, by_amplitude.frequency[usable], rtol=1e-9)
    np.testing.assert_allclose(by_force.damping, by_amplitude.damping[usable], rtol=1e-7)


@pytest.mark.parametrize("model, count", [("jenkins", 9), ("iwan4", 15), ("iwan5", 18), ("iwan4_stuck", 12)])
def test_brb_layout_has_the_papers_parameter_counts(model, count):
    """Paper Table 2: 9, 15, 18 and 12 unknowns for three symmetry groups."""
    assert len(parameter_names(model, 3)) == count
    design = random_designs(model, 1, 3, np.random.default_rng(0))
    elements = patch_elements(model, design, BRB_PATCH_GROUPS)
    np.testing.assert_array_equal(elements.stiffness[0, [0, 1]], elements.stiffness[0, [4, 3]])  # symmetry
    assert elements.stuck.tolist() == [False, False, model == "iwan4_stuck", False, False]


@pytest.mark.parametrize("model, change, message", [
    ("iwan4", {2: 0.3}, "chi"), ("iwan4", {1: -1e6}, "K_T"), ("iwan5", {4: 1.5}, "theta"),
    ("jenkins", {2: -1e8}, "K_z"), ("iwan4", {}, "takes 15 parameters"),
])
def test_designs_outside_the_physical_range_are_refused(model, change, message):
    design = random_designs(model, 1, 3, np.random.default_rng(1))[0]
    for index, value in change.items():
        design[index] = value
    if not change:
        design = design[:-1]
    with pytest.raises(FrictionParameterError, match=message):
        patch_elements(model, design, BRB_PATCH_GROUPS)


def test_qsma_refuses_an_unphysical_design_with_a_clear_error():
    with pytest.raises(FrictionParameterError, match="chi"):
        qsma_reference(two_body_space(), "iwan4", [300.0, 2.0e6, 0.4, 0.2, 1.0e7], amplitudes=[1e-6])
