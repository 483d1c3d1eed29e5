"""The one-mode joint model (``nonlinear.modal_joint``: one compiled kernel) against the elements' closed forms,
which it does not use: ``nonlinear.iwan``'s five-parameter backbone and dissipation (paper Eqs. 21-22) and
``nonlinear.jenkins``' (Eqs. 14-15), composed as omega(q)^2 = ((1 - sum_j kappa_j) omega_0^2 q + sum_j f_j(q)) / q
and zeta_J(q) = sum_j D_j(q) / (2 pi q^2 omega(q)^2), from deep microslip to deep macroslip of every element; the
parameters' ranges refused with the checks' errors."""

import itertools

import numpy as np
import pytest

from nonlinear import iwan, jenkins
from nonlinear.modal_joint import _in_range, modal_joint_backbone
from nonlinear.parameters import (FrictionParameterError, check_iwan, check_jenkins, check_stiction_ratio,
                                  in_range)

STUCK_FREQUENCY_HZ = 170.0
OMEGA_SQUARED_0 = (2.0 * np.pi * STUCK_FREQUENCY_HZ) ** 2

# (chi, None for Jenkins; beta; theta; the joint's element (kappa, F_S); a second element or None): both laws, one
# and two elements, chi near both ends of its range, a large and a vanishing spike, stiction.
CASES = [
    (None, 0.0, 1.0, (0.3, 2.0), None),
    (None, 0.0, 1.0, (0.3, 2.0), (0.05, 40.0)),
    (-0.4, 0.2, 1.0, (0.3, 2.0), None),
    (-0.95, 1.0e3, 0.2, (0.02, 300.0), (0.4, 5.0)),
    (-0.02, 1.0e-4, 0.7, (0.6, 1.0e-3), (0.1, 1.0e2)),
]


def macroslip_amplitude(chi, beta, kappa, slip_force):
    """The amplitude (m kg^0.5) at which an element reaches macroslip: phi_max."""
    stiffness = kappa * OMEGA_SQUARED_0
    return slip_force / stiffness if chi is None else iwan.segalman_constants(slip_force, stiffness, chi, beta)[0]


def closed_form_backbone(amplitude, chi, beta, theta, elements):
    """Frequency (Hz) and damping of the one-mode model composed from the elements' closed forms (module
    docstring)."""
    force = (1.0 - sum(kappa for kappa, _ in elements)) * OMEGA_SQUARED_0 * amplitude
    dissipation = np.zeros_like(amplitude)
    for kappa, slip_force in elements:
        stiffness = kappa * OMEGA_SQUARED_0
        if chi is None:
            force = force + jenkins.backbone(amplitude, stiffness, slip_force)
            dissipation = dissipation + jenkins.dissipation(amplitude, stiffness, slip_force)
        else:
            force = force + iwan.five_parameter_backbone(amplitude, slip_force, stiffness, chi, beta, theta)
            dissipation = dissipation + iwan.five_parameter_dissipation(amplitude, slip_force, stiffness, chi, beta,
                                                                        theta)
    omega_squared = force / amplitude
    return np.sqrt(omega_squared) / (2.0 * np.pi), dissipation / (2.0 * np.pi * amplitude ** 2 * omega_squared)


def subtracted_damping(amplitude, chi, beta, elements, frequency_hz):
    """The size, in damping units, of the terms the closed-form dissipations subtract beyond macroslip (Jenkins'
    4 F_S (u - F_S / K_T), Iwan's alike): 4 F_S q / (2 pi q^2 omega^2) of each element past its macroslip
    amplitude, 0 before it. Just past macroslip their difference is small against them."""
    omega_squared = (2.0 * np.pi * frequency_hz) ** 2
    return sum(np.where(amplitude > macroslip_amplitude(chi, beta, *element), 4.0 * element[1] * amplitude, 0.0)
               for element in elements) / (2.0 * np.pi * amplitude ** 2 * omega_squared)


@pytest.mark.parametrize("chi, beta, theta, element, second_stage", CASES)
def test_one_mode_model_is_the_elements_closed_forms(chi, beta, theta, element, second_stage):
    """From 1e-4 of the first element's macroslip amplitude to 1e3 times the last one's, and at each element's
    macroslip amplitude exactly where the law is continuous there (theta = 1: with stiction the model takes the
    static peak at phi_max, ``nonlinear.slip_laws``, the closed form the force after the drop), to 16 eps: both
    sides sum a few terms and take a square root and a quotient. Of each frequency: the sums have terms of one sign
    but the closed five-parameter backbone's microslip form, whose cancellation is a few eps of K_T u, at most
    1 / (1 - kappa) = 2.5 of the restoring force here. Of each damping plus the terms its closed form subtracts
    beyond macroslip (``subtracted_damping``), which cancel just past it. Measured: 1.5 eps of a frequency; 2.9 eps
    of that scale for a damping (28 eps of the value itself, a Jenkins element just past slip)."""
    elements = [element] + ([second_stage] if second_stage is not None else [])
    macroslip = sorted(macroslip_amplitude(chi, beta, *each) for each in elements)
    amplitude = np.geomspace(1e-4 * macroslip[0], 1e3 * macroslip[-1], 60)
    amplitude = np.sort(np.concatenate([amplitude, macroslip])) if theta == 1.0 else amplitude
    frequency, damping = modal_joint_backbone(amplitude, STUCK_FREQUENCY_HZ, *element, chi, beta, theta,
                                              second_stage)
    expected_frequency, expected_damping = closed_form_backbone(amplitude, chi, beta, theta, elements)
    tolerance = 16 * np.finfo(float).eps
    np.testing.assert_allclose(frequency, expected_frequency, rtol=tolerance, atol=0.0)
    scale = np.abs(expected_damping) + subtracted_damping(amplitude, chi, beta, elements, expected_frequency)
    assert np.all(np.abs(damping - expected_damping) <= tolerance * scale)  # stuck Jenkins: exactly 0
    # softening into macroslip (stuck: the same frequency to round-off)
    assert np.all(np.diff(frequency) <= 4 * np.finfo(float).eps * frequency[:-1])
    assert frequency[-1] < 0.9 * frequency[0]


def test_rows_of_parameters_are_each_rows_model():
    """Parameters as rows (b, 1) against amplitudes (n,) give (b, n), each row the model of its parameters alone,
    bit for bit (the discrepancy loop evaluates a Jacobian's parameter sets as rows of one call)."""
    rng = np.random.default_rng(3)
    amplitude = np.geomspace(1e-5, 1e-1, 25)
    kappa, slip_force = rng.uniform(0.01, 0.5, (6, 1)), np.exp(rng.uniform(-3.0, 5.0, (6, 1)))
    chi, beta = rng.uniform(-0.9, -0.1, (6, 1)), np.exp(rng.uniform(-5.0, 2.0, (6, 1)))
    frequency_hz = STUCK_FREQUENCY_HZ * (1.0 + rng.uniform(-0.01, 0.01, (6, 1)))
    rows = modal_joint_backbone(amplitude, frequency_hz, kappa, slip_force, chi, beta, 0.8, (kappa / 3, slip_force * 7))
    for row in range(6):
        alone = modal_joint_backbone(amplitude, float(frequency_hz[row, 0]), float(kappa[row, 0]),
                                     float(slip_force[row, 0]), float(chi[row, 0]), float(beta[row, 0]), 0.8,
                                     (float(kappa[row, 0] / 3), float(slip_force[row, 0] * 7)))
        assert rows[0].shape == rows[1].shape == (6, amplitude.size)
        assert np.array_equal(rows[0][row], alone[0]) and np.array_equal(rows[1][row], alone[1])


@pytest.mark.parametrize("change, message", [
    ({"chi": 0.1}, "chi"), ({"chi": -1.0}, "chi"), ({"beta": -0.1}, "beta"), ({"theta": 1.5}, "theta"),
    ({"slip_force": -1.0}, "slip force"), ({"kappa": 0.0}, "tangential stiffness"),
    ({"second_stage": (0.1, np.nan)}, "slip force"), ({"second_stage": (-0.1, 20.0)}, "tangential stiffness"),
    ({"chi": None, "slip_force": 0.0}, "slip force"), ({"chi": None, "second_stage": (0.0, 20.0)}, "stiffness"),
    ({"chi": None, "theta": 1.5}, "theta"), ({"amplitude": np.array([]), "chi": 0.5}, "chi"),
])
def test_parameters_outside_their_ranges_are_refused_by_name(change, message):
    parameters = {"amplitude": np.geomspace(1e-4, 1e-2, 5), "kappa": 0.3, "slip_force": 2.0, "chi": -0.4,
                  "beta": 0.2, "theta": 0.9, "second_stage": (0.1, 20.0), **change}
    with pytest.raises(FrictionParameterError, match=message):
        modal_joint_backbone(parameters["amplitude"], STUCK_FREQUENCY_HZ, parameters["kappa"],
                             parameters["slip_force"], parameters["chi"], parameters["beta"], parameters["theta"],
                             parameters["second_stage"])


def test_the_kernels_range_test_is_the_checks():
    """``nonlinear.parameters.in_range``, as Python and as compiled inside the kernel (which calls the checks only
    where it is False), accepts exactly what ``check_iwan`` and ``check_jenkins`` with ``check_stiction_ratio``
    accept, at and around every edge."""
    edges = [-np.inf, -2.0, -1.0, -0.999, -0.5, -1e-300, 0.0, 1e-300, 0.5, 1.0, 1.5, np.inf, np.nan]
    for slip_force, stiffness, chi, beta, theta in itertools.product(
            [-1.0, 0.0, 2.0, np.inf, np.nan], [0.0, 3.0e5, np.nan], edges, [-1.0, 0.0, 0.2, np.inf], edges):
        for iwan_law, check in ((True, lambda: check_iwan(slip_force, stiffness, chi, beta, theta)),
                                (False, lambda: (check_jenkins(stiffness, slip_force), check_stiction_ratio(theta)))):
            try:
                check()
                accepted = True
            except FrictionParameterError:
                accepted = False
            for range_test in (in_range, _in_range):
                assert range_test(slip_force, stiffness, chi, beta, theta, iwan_law) == accepted, (
                    range_test, slip_force, stiffness, chi, beta, theta, iwan_law)
