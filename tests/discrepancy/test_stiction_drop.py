"""A stiction drop on a measured level: stiction (theta < 1) drops an element's force at its slip amplitude, so the
one-mode backbone jumps there, and a fit's optimum can sit with the drop on a level.

- a one-sided difference across a jump is the jump over the step: the Jacobian takes the other side's slope
  (``across_jumps``), on a function with a unit step whose slope is known;
- the drop on a level is found, with the gap of levels that places it, and its row is the gradient of ln phi_max
  in closed form (Jenkins: phi_max = F_S / (kappa omega_0^2)) over the gap's uniform standard deviation; none for a
  drop between levels or without stiction, no row where the level is the last on its side;
- the gap bounds the covariance's standard deviation of ln phi_max whatever chi^2 per degree of freedom scales the
  points' part by;
- on the measured ASB C2 (the shared data, skipped where absent) the loop's answer, stiction at every level past
  its slip, sits on its drop at the lowest level: recorded, and its band at every fitted level within what a
  least-squares fit allows there, 1.96 sqrt(s) sigma (leverage at most 1, s = max(1, chi^2/dof); measured at most
  0.95 of it), where a gradient across the drop gave +-2e7 Hz.
"""

import numpy as np
import pytest
from scipy.special import expit, logit

from discrepancy.loop import (STAGE_SUFFIX, across_jumps, forward_difference_jacobian, model_variables,
                              parameter_covariance, smooth_jacobian, stiction_drops)
from locations import ASB_BACKBONES

F0 = 169.86
AMPLITUDE = np.geomspace(2e-6, 1.5e-4, 20)
SPECIFICATION = model_variables(("stiction",))  # kappa (logit), slip_force (log), theta (logit)


def step_residuals(rows):
    """Residuals (b, 2) of variables (b, 2): x0^2 and x0 + x1 + 5 where x1 >= 1 (a unit slope with a jump of 5)."""
    rows = np.atleast_2d(rows)
    return np.column_stack([rows[:, 0] ** 2, rows[:, 0] + rows[:, 1] + 5.0 * (rows[:, 1] >= 1.0)])


@pytest.mark.parametrize("x1", [1.0, np.nextafter(1.0, 0.0)])
def test_a_jacobian_column_across_a_jump_takes_the_other_sides_slope(x1):
    """At x1 = 1 the backward difference crosses the jump, just below 1 the forward one does: either way the column
    is the slope 1 of the side the point is on, and the smooth column (2 x0) is the forward difference's."""
    vector = np.array([2.0, x1])
    forward = forward_difference_jacobian(step_residuals, vector)
    smooth = smooth_jacobian(step_residuals, vector, forward)
    np.testing.assert_allclose(smooth[:, 1], [0.0, 1.0], atol=1e-6)
    np.testing.assert_array_equal(smooth[:, 0], forward[:, 0])
    backward = np.array([[4.0, 0.0], [1.0, 1.0]])
    np.testing.assert_array_equal(across_jumps(forward, forward, backward)[:, 0], forward[:, 0])


def jenkins_vector(kappa, slip_amplitude, theta=0.6):
    """The variables of a Jenkins joint with stiction whose slip amplitude F_S / (kappa omega_0^2) is given."""
    slip_force = slip_amplitude * kappa * (2 * np.pi * F0) ** 2
    return np.array([logit((kappa - 1e-6) / (1 - 2e-6)), np.log(slip_force), logit((theta - 1e-6) / (1 - 2e-6))])


@pytest.mark.parametrize("level", [5, 12])
def test_a_drop_on_a_level_is_found_with_its_gap_and_its_row_in_closed_form(level):
    kappa = 0.12
    vector = jenkins_vector(kappa, AMPLITUDE[level] * (1 - 1e-9))  # the level just past the slip
    reasons, rows = stiction_drops(vector, SPECIFICATION, AMPLITUDE, F0)
    assert list(reasons) == ["joint element"] and f"between {AMPLITUDE[level - 1]:.4g} and" in reasons["joint element"]
    spread = np.log(AMPLITUDE[level] / AMPLITUDE[level - 1]) / np.sqrt(12.0)
    share = expit(vector[0])
    d_kappa = (1 - 2e-6) * share * (1 - share)  # d kappa / d logit
    np.testing.assert_allclose(rows, [[-d_kappa / kappa / spread, 1.0 / spread, 0.0]], rtol=1e-6, atol=1e-6)


def test_no_drop_between_levels_without_stiction_or_a_gap():
    between = jenkins_vector(0.12, np.sqrt(AMPLITUDE[5] * AMPLITUDE[6]))
    assert stiction_drops(between, SPECIFICATION, AMPLITUDE, F0)[0] == {}
    on_level = jenkins_vector(0.12, AMPLITUDE[5])[:2]  # no theta: no stiction
    assert stiction_drops(on_level, model_variables(()), AMPLITUDE, F0)[0] == {}
    lowest = jenkins_vector(0.12, AMPLITUDE[0] * (1 - 1e-9))
    reasons, rows = stiction_drops(lowest, SPECIFICATION, AMPLITUDE, F0)
    assert "one side only" in reasons["joint element"] and rows.shape == (0, 3)


def test_the_gap_bounds_the_slip_amplitude_whatever_scales_the_points():
    """Points that leave ln phi_max free (a Jacobian with a nearly singular direction), chi^2/dof 12: with the gap's
    row the variance of ln phi_max is at most the gap's, not 12 times it; without it, it is huge."""
    vector = jenkins_vector(0.12, AMPLITUDE[8] * (1 - 1e-9))
    _, rows = stiction_drops(vector, SPECIFICATION, AMPLITUDE, F0)
    gradient = rows[0] * (np.log(AMPLITUDE[8] / AMPLITUDE[7]) / np.sqrt(12.0))
    jacobian = np.array([[1.0, 1.0, 0.0], [1.0, 1.0 + 1e-9, 0.0], [0.0, 0.0, 3.0]]) * 10.0
    bounded = parameter_covariance(jacobian, 12.0 * 100, 100, rows)
    free = parameter_covariance(jacobian, 12.0 * 100, 100)
    spread = np.log(AMPLITUDE[8] / AMPLITUDE[7]) / np.sqrt(12.0)
    assert gradient @ bounded @ gradient <= spread ** 2 * (1 + 1e-9)
    assert gradient @ free @ gradient > 1e6 * spread ** 2


C2 = ASB_BACKBONES / "ASB_C2_20Nm_BB.mat"


@pytest.mark.skipif(not C2.is_file(), reason=f"{C2} not found (the ASB's measured backbones)")
def test_measured_stiction_answer_on_its_drop_has_a_band_the_points_allow():
    from discrepancy.fitted_model import Z_95, evaluate, model_record
    from discrepancy.workflow import measured_input
    from study.structures import N_LEVELS

    loop = measured_input(C2, N_LEVELS, None, None).loop
    measurement, frequency, damping = loop.args
    verdict = loop()
    final = verdict.final
    assert "stiction" in final.effects and "kappa" + STAGE_SUFFIX not in final.parameters
    assert "one side only" in final.on_drop["joint element"]
    curves = evaluate(model_record(final, measurement, frequency, damping), measurement.amplitude)
    n = 2 * measurement.amplitude.size
    bound = Z_95 * np.sqrt(max(1.0, final.chi_squared / (n - final.n_parameters)))
    for band, sigma in ((curves["frequency_band"], measurement.sigma_frequency),
                        (curves["damping_band"], measurement.sigma_damping)):
        ratio = np.diff(band, axis=0)[0] / 2 / sigma
        assert np.all(ratio <= bound * 1.01), ratio / bound
