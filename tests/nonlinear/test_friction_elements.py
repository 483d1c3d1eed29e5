"""Friction elements: closed forms against Masing's rule and against discretised slider elements.

Physics checked: the closed-form cycle dissipations (paper Eqs. 15, 19, 22) are Masing's Eq. (13) applied to
the closed-form backbones (Eqs. 14, 18, 21); a many-slider element driven through a cycle traces the same
backbone and loop; Iwan microslip dissipation is a power law of exponent chi + 3; theta = 1 is the
four-parameter model; unphysical parameters are refused.
"""

import numpy as np
import pytest
from scipy.integrate import quad

from nonlinear import iwan, jenkins, slip_laws
from nonlinear.parameters import FrictionParameterError
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import (patch_elements, random_designs, scaled_law, slip_displacement,
                             tangential_dissipation, tangential_elements, tangential_force, tangential_slip_deficit,
                             tangential_tangent)
from nonlinear.sliders import initial_state, iwan_sliders, jenkins_sliders, slider_response

# (F_S N, K_T N/m, chi, beta, theta) spanning Table 3: soft/strong, stiff/weak, chi near both ends.
IWAN_CASES = [
    (1.0e3, 1.0e7, -0.5, 0.1, 0.7),
    (5.0e9, 3.0e2, -0.95, 1.0e3, 0.2),
    (2.0e1, 1.0e13, -0.02, 1.0e-4, 1.0),
    (7.0e5, 4.0e9, -0.3, 0.0, 0.5),
]
# Amplitudes in units of the macroslip displacement phi_max: deep microslip to macroslip.
SCALED_AMPLITUDES = [0.05, 0.3, 0.9, 1.0 + 1e-3, 1.5, 4.0]


def masing_dissipation(backbone, amplitude, kink):
    """Paper Eq. (13): D(u0) = -4 f(u0) u0 + 8 int_0^u0 f(t) dt, integrated numerically (J)."""
    points = [kink] if kink < amplitude else None
    area, _ = quad(backbone, 0.0, amplitude, points=points, epsabs=0.0, epsrel=1e-13, limit=200)
    return -4.0 * backbone(amplitude) * amplitude + 8.0 * area


def drive_cycle(sliders, amplitude, steps=2000):
    """Load a virgin element to +u0, then through -u0 back to +u0 (a full steady Masing loop).

    Returns (u, f) of the initial loading and (u, f) of the closed loop.
    """
    ramp = np.linspace(0.0, amplitude, steps)
    loop = np.concatenate([np.linspace(amplitude, -amplitude, 2 * steps),
                           np.linspace(-amplitude, amplitude, 2 * steps)])
    position, direction = initial_state(sliders)
    forces = []
    for u in np.concatenate([ramp, loop]):
        force, _, position, direction = slider_response(u, position, direction, sliders)
        forces.append(float(force))
    forces = np.array(forces)
    return (ramp, forces[:steps]), (loop, forces[steps:])


def loop_area(u, f):
    """Energy dissipated around a closed loop, the integral of f du (J)."""
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(u)))


@pytest.mark.parametrize("slip_force, stiffness", [(1.0e3, 1.0e7), (3.0e10, 2.0e2), (10.0, 1.0e14)])
@pytest.mark.parametrize("scaled_amplitude", [0.5, 1.2, 30.0])
def test_jenkins_dissipation_is_masing_integral_of_backbone(slip_force, stiffness, scaled_amplitude):
    u_slip = slip_force / stiffness
    amplitude = scaled_amplitude * u_slip
    numerical = masing_dissipation(lambda u: jenkins.backbone(u, stiffness, slip_force), amplitude, u_slip)
    closed = jenkins.dissipation(amplitude, stiffness, slip_force)
    assert closed == pytest.approx(numerical, rel=1e-8, abs=1e-12 * slip_force * u_slip)


@pytest.mark.parametrize("case", IWAN_CASES)
@pytest.mark.parametrize("scaled_amplitude", SCALED_AMPLITUDES)
def test_iwan_dissipations_are_masing_integrals_of_backbones(case, scaled_amplitude):
    slip_force, stiffness, chi, beta, theta = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    amplitude = scaled_amplitude * phi_max
    four = masing_dissipation(lambda u: iwan.four_parameter_backbone(u, slip_force, stiffness, chi, beta),
                              amplitude, phi_max)
    five = masing_dissipation(lambda u: iwan.five_parameter_backbone(u, slip_force, stiffness, chi, beta, theta),
                              amplitude, phi_max)
    assert iwan.four_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta) == pytest.approx(four, rel=1e-8)
    assert iwan.five_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta, theta) == pytest.approx(
        five, rel=1e-8)


@pytest.mark.parametrize("case", IWAN_CASES)
def test_segalman_mapping_gives_macroslip_force_and_initial_stiffness(case):
    slip_force, stiffness, chi, beta, _ = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    assert iwan.four_parameter_backbone(2.0 * phi_max, slip_force, stiffness, chi, beta) == pytest.approx(
        slip_force, rel=1e-13)
    assert iwan.four_parameter_tangent(0.0, slip_force, stiffness, chi, beta) == pytest.approx(stiffness, rel=1e-13)
    # The tangent is the derivative of the backbone (central difference, relative step 1e-6).
    u, h = 0.4 * phi_max, 1e-6 * phi_max
    for backbone, tangent, extra in [(iwan.four_parameter_backbone, iwan.four_parameter_tangent, ()),
                                     (iwan.five_parameter_backbone, iwan.five_parameter_tangent, (case[4],))]:
        slope = (backbone(u + h, slip_force, stiffness, chi, beta, *extra)
                 - backbone(u - h, slip_force, stiffness, chi, beta, *extra)) / (2 * h)
        assert tangent(u, slip_force, stiffness, chi, beta, *extra) == pytest.approx(slope, rel=1e-6)


@pytest.mark.parametrize("case", IWAN_CASES)
def test_theta_one_is_the_four_parameter_model(case):
    slip_force, stiffness, chi, beta, _ = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    u = phi_max * np.array([0.0, 1e-4, 0.2, 0.7, 0.999, 1.0, 1.5, 10.0])
    args = (slip_force, stiffness, chi, beta)
    np.testing.assert_allclose(iwan.five_parameter_backbone(u, *args, 1.0), iwan.four_parameter_backbone(u, *args),
                               rtol=1e-14, atol=0)
    np.testing.assert_allclose(iwan.five_parameter_tangent(u, *args, 1.0), iwan.four_parameter_tangent(u, *args),
                               rtol=1e-14, atol=1e-14 * stiffness)
    np.testing.assert_allclose(iwan.five_parameter_dissipation(u, *args, 1.0),
                               iwan.four_parameter_dissipation(u, *args), rtol=1e-14, atol=0)


@pytest.mark.parametrize("chi", [-0.9, -0.5, -0.05])
def test_iwan_microslip_dissipation_is_power_law_of_exponent_chi_plus_3(chi):
    """Log-slope of Masing's numerically integrated dissipation over two decades of deep microslip."""
    slip_force, stiffness, beta, theta = 1.0e4, 1.0e8, 0.5, 0.6
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    amplitudes = phi_max * np.array([1e-4, 1e-3, 1e-2])
    for backbone in [lambda u: iwan.four_parameter_backbone(u, slip_force, stiffness, chi, beta),
                     lambda u: iwan.five_parameter_backbone(u, slip_force, stiffness, chi, beta, theta)]:
        dissipation = [masing_dissipation(backbone, a, phi_max) for a in amplitudes]
        slopes = np.diff(np.log(dissipation)) / np.diff(np.log(amplitudes))
        np.testing.assert_allclose(slopes, chi + 3.0, rtol=1e-6)


def test_single_slider_cycle_is_the_jenkins_element():
    stiffness, slip_force = 2.0e6, 150.0
    amplitude = 3.0 * slip_force / stiffness
    (u, f), (u_loop, f_loop) = drive_cycle(jenkins_sliders(stiffness, slip_force), amplitude, steps=3000)
    np.testing.assert_allclose(f, jenkins.backbone(u, stiffness, slip_force), rtol=1e-12, atol=1e-9 * slip_force)
    # Piecewise-linear loop: the trapezoid rule is exact except for the two steps containing a kink.
    assert loop_area(u_loop, f_loop) == pytest.approx(jenkins.dissipation(amplitude, stiffness, slip_force), rel=1e-3)


@pytest.mark.parametrize("case", IWAN_CASES)
@pytest.mark.parametrize("scaled_amplitude", [0.3, 0.8, 2.0])
def test_many_slider_iwan_reproduces_backbone_and_loop_area(case, scaled_amplitude):
    """About 2,500 sliders: backbone within 0.5 % above 2 % of the amplitude, loop area within 0.5 %."""
    slip_force, stiffness, chi, beta, theta = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    amplitude = scaled_amplitude * phi_max
    sliders = iwan_sliders(slip_force, stiffness, chi, beta, theta)
    (u, f), (u_loop, f_loop) = drive_cycle(sliders, amplitude)
    far_from_origin = u > 0.02 * amplitude
    exact = iwan.five_parameter_backbone(u, slip_force, stiffness, chi, beta, theta)
    np.testing.assert_allclose(f[far_from_origin], exact[far_from_origin], rtol=5e-3)
    exact_loop = iwan.five_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta, theta)
    assert loop_area(u_loop, f_loop) == pytest.approx(exact_loop, rel=5e-3)


@pytest.mark.parametrize("bad, message", [
    (dict(chi=0.2), "chi"), (dict(chi=-1.0), "chi"), (dict(stiffness=-1.0e6), "K_T"),
    (dict(slip_force=0.0), "F_S"), (dict(theta=1.2), "theta"), (dict(theta=-0.1), "theta"), (dict(beta=-1.0), "beta"),
])
def test_unphysical_parameters_are_refused(bad, message):
    parameters = dict(slip_force=1.0e3, stiffness=1.0e7, chi=-0.5, beta=0.1, theta=0.5) | bad
    with pytest.raises(FrictionParameterError, match=message):
        iwan.five_parameter_backbone(1e-5, **parameters)
    with pytest.raises(FrictionParameterError, match=message):
        iwan_sliders(**parameters)
    with pytest.raises(FrictionParameterError):
        jenkins.dissipation(1e-4, stiffness=-5.0, slip_force=1.0)


@pytest.mark.parametrize("case", IWAN_CASES)
def test_slip_deficit_is_stuck_force_minus_backbone(case):
    """K_T u - f(u) from its cancellation-free closed form, and its derivative K_T - f'(u)."""
    slip_force, stiffness, chi, beta, theta = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    u = phi_max * np.array([-3.0, -0.4, 0.3, 0.9, 1.7])
    args = (slip_force, stiffness, chi, beta)
    scale = slip_force * 1e-12
    np.testing.assert_allclose(iwan.four_parameter_slip_deficit(u, *args),
                               stiffness * u - iwan.four_parameter_backbone(u, *args), rtol=1e-10, atol=scale)
    np.testing.assert_allclose(iwan.five_parameter_slip_deficit(u, *args, theta),
                               stiffness * u - iwan.five_parameter_backbone(u, *args, theta), rtol=1e-10, atol=scale)
    np.testing.assert_allclose(iwan.four_parameter_slip_deficit_tangent(u, *args),
                               stiffness - iwan.four_parameter_tangent(u, *args), rtol=1e-10, atol=1e-12 * stiffness)
    np.testing.assert_allclose(iwan.five_parameter_slip_deficit_tangent(u, *args, theta),
                               stiffness - iwan.five_parameter_tangent(u, *args, theta), rtol=1e-10,
                               atol=1e-12 * stiffness)
    u_jenkins = np.array([-3.0, 0.5, 2.0]) * slip_force / stiffness
    np.testing.assert_allclose(jenkins.slip_deficit(u_jenkins, stiffness, slip_force),
                               stiffness * u_jenkins - jenkins.backbone(u_jenkins, stiffness, slip_force),
                               rtol=1e-12, atol=scale)
    np.testing.assert_allclose(jenkins.slip_deficit_tangent(u_jenkins, stiffness, slip_force),
                               stiffness - jenkins.tangent(u_jenkins, stiffness, slip_force), rtol=1e-12)


@pytest.mark.parametrize("case", IWAN_CASES)
def test_slip_deficit_potential_is_integral_of_deficit(case):
    """The potential's central difference is the deficit (micro- and macroslip), relative step 1e-6."""
    slip_force, stiffness, chi, beta, theta = case
    phi_max, _, _ = iwan.segalman_constants(slip_force, stiffness, chi, beta)
    u, h = phi_max * np.array([0.05, 0.5, 0.95, 1.3, 4.0]), 1e-6 * phi_max
    args = (slip_force, stiffness, chi, beta)
    for potential, deficit in [(lambda v: iwan.four_parameter_slip_deficit_potential(v, *args),
                                lambda v: iwan.four_parameter_slip_deficit(v, *args)),
                               (lambda v: iwan.five_parameter_slip_deficit_potential(v, *args, theta),
                                lambda v: iwan.five_parameter_slip_deficit(v, *args, theta))]:
        np.testing.assert_allclose((potential(u + h) - potential(u - h)) / (2 * h), deficit(u), rtol=1e-6)
    u_jenkins = np.array([0.5, 1.5, 7.0]) * slip_force / stiffness
    h = 1e-6 * slip_force / stiffness
    np.testing.assert_allclose((jenkins.slip_deficit_potential(u_jenkins + h, stiffness, slip_force)
                                - jenkins.slip_deficit_potential(u_jenkins - h, stiffness, slip_force)) / (2 * h),
                               jenkins.slip_deficit(u_jenkins, stiffness, slip_force), rtol=1e-6,
                               atol=1e-9 * slip_force)


@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan5", "iwan4_stuck", "iwan4_core"])
def test_tangential_force_is_stiffness_less_slip_deficit(model):
    """The backbone force of ``tangential_force`` equals (K_T + K_c) u - g(u) of the scaled slip law on Table 3
    elements from stuck to 1e3 slip displacements (K_c = 0 but for the stuck core), within the round-off of that
    difference (4 eps ((K_T + K_c) |u| + |g|))."""
    elements = tangential_elements(patch_elements(model, random_designs(model, 200, 3, np.random.default_rng(3))))
    rng = np.random.default_rng(4)
    scaled = rng.choice([-1, 1], elements.stiffness.shape) * np.geomspace(1e-6, 1e3, elements.stiffness.size).reshape(
        elements.stiffness.shape)
    displacement = scaled * np.where(elements.stuck, 1e-3, slip_displacement(elements))
    deficit = tangential_slip_deficit(elements, displacement)
    stuck_tangent = elements.stiffness + elements.core_stiffness
    difference = stuck_tangent * displacement - deficit
    round_off = 4 * np.finfo(float).eps * (stuck_tangent * np.abs(displacement) + np.abs(deficit))
    assert np.all(np.abs(tangential_force(elements, displacement) - difference) <= round_off + 1e-12 * np.abs(difference))


def closed_forms(elements, u):
    """Tangent (N/m), force (N) and Masing dissipation (J) at u of paper Eqs. 14-22 in closed form
    (``nonlinear.jenkins``, ``nonlinear.iwan``), dispatched on the law; stuck patches K_T, K_T u, 0; a core spring
    in parallel adds K_c and K_c u."""
    e = elements
    if e.model.element == "jenkins":
        forms = (jenkins.tangent(u, e.stiffness, e.slip_force), jenkins.backbone(u, e.stiffness, e.slip_force),
                 jenkins.dissipation(u, e.stiffness, e.slip_force))
    elif e.model.element == "iwan4":
        args = (e.slip_force, e.stiffness, e.chi, e.beta)
        forms = (iwan.four_parameter_tangent(u, *args), iwan.four_parameter_backbone(u, *args),
                 iwan.four_parameter_dissipation(u, *args))
    else:
        args = (e.slip_force, e.stiffness, e.chi, e.beta, e.theta)
        forms = (iwan.five_parameter_tangent(u, *args), iwan.five_parameter_backbone(u, *args),
                 iwan.five_parameter_dissipation(u, *args))
    tangent, force, dissipation = (np.where(e.stuck, stuck, form) for stuck, form in
                                   zip((e.stiffness, e.stiffness * u, 0.0), forms))
    return tangent + e.core_stiffness, force + e.core_stiffness * u, dissipation


def table3_elements_from_stuck_to_deep_macroslip(model, seed):
    """Tangential elements of 200 random Table 3 designs and a displacement for each, 1e-6 to 1e6 slip
    displacements (1e-3 m for stuck patches), both signs, shuffled over the elements."""
    elements = tangential_elements(patch_elements(model, random_designs(model, 200, 3, np.random.default_rng(seed))))
    rng = np.random.default_rng(seed + 1)
    shape = elements.stiffness.shape
    magnitudes = rng.permutation(np.geomspace(1e-6, 1e6, elements.stiffness.size)).reshape(shape)
    scaled = rng.choice([-1, 1], shape) * magnitudes
    return elements, scaled * np.where(elements.stuck, 1e-3, slip_displacement(elements))


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_branch_free_tangent_force_and_dissipation_are_the_closed_forms(model):
    """``tangential_tangent``, ``_force`` and ``_dissipation`` (one scaled slip law, ``nonlinear.slip_laws``)
    equal the closed forms of Eqs. 14-22 on Table 3 elements from stuck to deep macroslip. Both sides sum a few
    terms with the same constants phi_max, r, s; a sum is within a few eps of the sum of its terms' magnitudes,
    bounded by K_T for a tangent, K_T min(|u|, phi_max) for a force (plus K_c and K_c |u| of a core) and
    4 K_T phi_max (theta |u| + phi_max) for a dissipation beyond macroslip (none of the closed dissipation's terms
    cancel in microslip). So they agree to 1e-12 of that scale, 4500 eps (measured: at most 5 eps; relative to the
    value itself 5e-14, where the closed five-parameter tangent cancels near macroslip with a small spike beta)."""
    elements, u = table3_elements_from_stuck_to_deep_macroslip(model, 5)
    phi_max = np.where(elements.stuck, np.inf, slip_displacement(elements))
    beyond = np.abs(u) > phi_max
    scales = (elements.stiffness + elements.core_stiffness,
              elements.stiffness * np.minimum(np.abs(u), phi_max) + elements.core_stiffness * np.abs(u),
              np.where(beyond, 4.0 * elements.stiffness * phi_max * (elements.theta * np.abs(u) + phi_max), 0.0))
    branch_free = (tangential_tangent(elements, u), tangential_force(elements, u), tangential_dissipation(elements, u))
    for name, value, closed, scale in zip(("tangent", "force", "dissipation"), branch_free, closed_forms(elements, u),
                                          scales):
        error = np.abs(value - closed)
        assert np.all(error <= 1e-12 * (np.abs(closed) + scale)), (name, np.max(error / (np.abs(closed) + scale)))


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_masing_dissipation_is_the_kernels_formula_without_its_cancellation(model):
    """slip_laws.masing_dissipation is x g - 2 G (the QSMA kernel's Masing formula, from the slip deficit and its
    integral) to that difference's round-off, 32 eps (|x g| + 2 |G|) (three powers and a few products; 9 eps
    measured): in deep macroslip both grow as x^2 while their difference grows as x, and the sum of terms >= 0
    keeps the digits the difference loses."""
    elements, u = table3_elements_from_stuck_to_deep_macroslip(model, 7)
    law = scaled_law(elements)
    x = u / law.phi_max
    g = slip_laws.slip_deficit(x, law.r, law.s, law.chi, law.theta)
    potential = slip_laws.slip_deficit_potential(x, law.r, law.s, law.chi, law.theta)
    kernel = x * g - 2.0 * potential
    value = slip_laws.masing_dissipation(x, law.r, law.s, law.chi, law.theta)
    assert np.all(value >= 0.0)
    assert np.all(np.abs(value - kernel) <= 32 * np.finfo(float).eps * (np.abs(x * g) + 2.0 * np.abs(potential)))
