"""Harmonic balance machinery: the Fourier basis, the AFT's periodic hysteresis and its analytic Jacobian against
finite differences, the static step against its closed form, and the continuation."""

import numpy as np
import pytest

from nonlinear.epmc import ModeEquations
from nonlinear.friction_models import friction_model
from nonlinear.harmonic_balance import (JointSystem, fourier_basis, periodic_hysteresis,
                                        periodic_hysteresis_reference, pseudo_arclength, slip_deficit_harmonics,
                                        stacked_sliders, static_equilibrium, virgin_state)
from nonlinear.sliders import jenkins_sliders

ELEMENTS = [  # (model, F_S N, K_T N/m, chi, beta, theta): the three laws of the registry, one element each
    ("jenkins", 40.0, 2.0e6, -0.5, 0.0, 1.0),
    ("iwan4", 60.0, 3.0e6, -0.4, 0.3, 1.0),
    ("iwan5", 50.0, 1.0e6, -0.7, 2.0, 0.8),
]


def three_element_system() -> JointSystem:
    """Three modes of 100, 180 and 310 Hz (identity mass) whose joint motions mix three friction elements: a
    Jenkins, a four- and a five-parameter (stiction) Iwan element."""
    rng = np.random.default_rng(7)
    sliders = [friction_model(model).sliders(slip, stiffness, chi, beta, theta)
               for model, slip, stiffness, chi, beta, theta in ELEMENTS]
    return JointSystem((2 * np.pi * np.array([100.0, 180.0, 310.0])) ** 2, np.eye(3),
                       rng.normal(size=(3, 3)) * 0.3 + np.eye(3), 0,
                       np.array([element[2] for element in ELEMENTS]), stacked_sliders(sliders))


def test_fourier_basis_inverts_on_the_samples():
    """P E = I: the harmonics of a series sampled at N > 2H points are recovered exactly."""
    to_time, to_harmonics = fourier_basis(5, 16)
    np.testing.assert_allclose(to_harmonics @ to_time, np.eye(11), atol=1e-14)
    with pytest.raises(ValueError, match="cannot carry 8 harmonics"):
        fourier_basis(8, 16)


def test_jenkins_hysteresis_is_the_masing_loop():
    """A Jenkins element under u0 cos(tau) from the virgin state: periodic after the first period, and the
    last period's force is the closed-form loop: F_S - K_T (u0 - u) from the reversal at u0, clipped at -F_S."""
    stiffness, slip = 2.0e6, 40.0
    system = JointSystem(np.ones(1), np.eye(1), np.ones((1, 1)), 0, np.array([stiffness]),
                         stacked_sliders([jenkins_sliders(stiffness, slip)]))
    samples = 64
    tau = 2 * np.pi * np.arange(samples) / samples
    u0 = 5 * slip / stiffness
    u = u0 * np.cos(tau)[None, :]
    hysteresis = periodic_hysteresis(system, u, virgin_state(system.sliders))
    assert hysteresis.periodic and hysteresis.periods == 2
    falling = np.maximum(slip - stiffness * (u0 - u[0]), -slip)
    rising = np.minimum(-slip + stiffness * (u[0] + u0), slip)
    force = np.where(tau <= np.pi, falling, rising)
    np.testing.assert_allclose(stiffness * u[0] - hysteresis.deficit[0], force, rtol=0, atol=1e-9 * slip)


def test_compiled_time_loop_equals_its_numpy_oracle():
    """The compiled time loop and the numpy one (``slider_response`` per sample) on the three laws under a motion
    of three harmonics, from the virgin state and from a preloaded one: the same periods, forces to 1e-12 of the
    slip force, the Jacobian to 1e-12 of the stiffest element (its sums in another order), the same final state."""
    system = three_element_system()
    to_time, _ = fourier_basis(3, 64)
    rng = np.random.default_rng(5)
    motion = (to_time @ (rng.normal(size=(7, 3)) * 3e-5)).T
    preloaded = static_equilibrium(system, np.array([3e3, -1e4, 2e4]))[1]
    for state in (virgin_state(system.sliders), preloaded):
        compiled = periodic_hysteresis(system, motion, state)
        reference = periodic_hysteresis_reference(system, motion, state)
        assert compiled.periodic and compiled.periods == reference.periods
        np.testing.assert_allclose(compiled.deficit, reference.deficit, rtol=0, atol=1e-12 * 60.0)
        np.testing.assert_allclose(compiled.jacobian, reference.jacobian, rtol=0, atol=1e-12 * 3e6)  # sums reordered
        np.testing.assert_array_equal(compiled.state.direction, reference.state.direction)
        np.testing.assert_allclose(compiled.state.position, reference.state.position, rtol=0, atol=1e-18)


def finite_difference_columns(function, x, relative_step=1e-9):
    """Forward differences of a vector function at x, one column per entry, step relative to max |x|.

    The step is small because the stiction element's force jumps by (1 - theta) f_j where slider j breaks loose:
    a step that moves a breakaway across a sample measures that jump over the step, not the derivative (at
    1e-7 one of the 23 columns below is off by 3 %, at 1e-8 by 30 %: an error growing as the step shrinks)."""
    step = relative_step * np.abs(x).max()
    base = function(x)
    return np.column_stack([(function(x + step * unit) - base) / step for unit in np.eye(x.size)])


def test_aft_jacobian_matches_finite_differences():
    """dG/dU of the three laws (Jenkins, Iwan with thousands of sliders, stiction) through the AFT, at a motion
    of three harmonics in micro- and macroslip, against forward differences: within 1e-5 of its largest entry."""
    system = three_element_system()
    basis = fourier_basis(3, 128)
    rng = np.random.default_rng(1)
    motion = rng.normal(size=(7, 3)) * np.array([0.2, 1.0, 0.5]) * 3e-5  # m: element 2 deep, 0 barely slipping
    motion[1] += np.array([2.5e-5, 3e-5, 8e-5])
    state = virgin_state(system.sliders)
    analytic = slip_deficit_harmonics(system, motion, basis, state)
    assert analytic.periodic
    for element in range(3):
        def harmonics(x, element=element):
            trial = motion.copy()
            trial[:, element] = x
            return slip_deficit_harmonics(system, trial, basis, state).harmonics[:, element]
        numeric = finite_difference_columns(harmonics, motion[:, element])
        scale = np.abs(analytic.jacobian[element]).max()
        assert scale > 0.05 * ELEMENTS[element][2]  # slipping, yet not every slider slides
        np.testing.assert_allclose(analytic.jacobian[element], numeric, rtol=0, atol=1e-5 * scale)


def test_epmc_residual_jacobian_matches_finite_differences():
    """The EPMC residual's Jacobian in the joint harmonics, omega and xi, and its derivative in ln q, against
    forward differences at a point off the solution (every term nonzero)."""
    system = three_element_system()
    equations = ModeEquations(system, harmonics=3, samples=128)
    rng = np.random.default_rng(3)
    log_amplitude = np.log(4e-5)
    y = equations.linear_mode(np.exp(log_amplitude))
    y[:-2] += rng.normal(size=y.size - 2) * 0.2
    y[-2:] = [0.97, 0.01]
    residual, jacobian, derivative = equations(y, log_amplitude)
    numeric = finite_difference_columns(lambda x: equations(x, log_amplitude)[0], y)
    np.testing.assert_allclose(jacobian, numeric, rtol=0, atol=1e-5 * np.abs(jacobian).max())
    step = 1e-7
    numeric_derivative = (equations(y, log_amplitude + step)[0] - residual) / step
    np.testing.assert_allclose(derivative, numeric_derivative, rtol=0, atol=1e-5 * np.abs(derivative).max())


def test_static_step_is_the_closed_form_of_a_preloaded_jenkins():
    """One mode (mu = k + K_T) with a Jenkins element: a static load P below F_S (1 + k / K_T) holds it stuck,
    r = P / (k + K_T); above, the slider slides and r = (P - F_S) / k. The slider is left where it slid."""
    k, stiffness, slip = 1.0e6, 2.0e6, 40.0
    system = JointSystem(np.array([k + stiffness]), np.eye(1), np.ones((1, 1)), 0, np.array([stiffness]),
                         stacked_sliders([jenkins_sliders(stiffness, slip)]))
    r, state = static_equilibrium(system, np.array([30.0]))
    np.testing.assert_allclose(r, 30.0 / (k + stiffness), rtol=1e-14)
    assert np.all(state.direction == 0)
    r, state = static_equilibrium(system, np.array([100.0]))
    np.testing.assert_allclose(r, (100.0 - slip) / k, rtol=1e-13)
    np.testing.assert_allclose(state.position[:, 0], r - slip / stiffness, rtol=1e-13)


def test_pseudo_arclength_follows_a_curved_branch():
    """The circle x^2 + p^2 = 1 from (x, p) = (-0.6, -0.8) with increasing p to p = 0.8, through x = -1 where
    x turns: every point on the circle, p increasing, each stop a point of the branch exactly."""
    def residual(y, p):
        return np.array([y[0] ** 2 + p ** 2 - 1.0]), np.array([[2 * y[0]]]), np.array([2 * p])

    stops = [-0.5, 0.0, 0.3, 0.8]
    branch = pseudo_arclength(residual, np.array([-0.6]), -0.8, stops, 0.05)
    np.testing.assert_allclose(branch.unknowns[:, 0] ** 2 + branch.parameters ** 2, 1.0, atol=1e-10)
    assert branch.reached and np.all(np.diff(branch.parameters) > 0)
    np.testing.assert_array_equal(branch.parameters[branch.at_stops], stops)
