"""The discrepancy fit's Jacobian (``discrepancy.loop.forward_difference_jacobian``): its p + 1 parameter sets
evaluated as rows of one call of the one-mode model give scipy's forward differences column by column, and a fit
with it reaches the optimum of scipy's own "2-point" Jacobian (virtual backbones of the one-mode model)."""

import numpy as np
from scipy.optimize import approx_fprime, least_squares

from discrepancy.loop import (_to_parameters, _to_vector, best_least_squares, forward_difference_jacobian,
                              model_backbone, model_variables, weighted_misfit)
from test_model_selection import AMPLITUDES, F0, JOINT, ZETA0, virtual_measurement

EFFECTS = ("microslip", "second_slip_stage", "cubic_stiffening")
TRUTH = {"chi": -0.4, "beta": 0.3, "kappa_2": 0.05, "slip_force_2": 0.05 * (2 * np.pi * F0) ** 2 * 1e-5,
         "cubic": 0.01}


def residual_rows(measurement):
    """Rows of fitted variables (b, p) of the model with ``EFFECTS`` -> rows of weighted residuals (b, 2n)."""
    specification = model_variables(EFFECTS)

    def residuals(rows):
        parameters = _to_parameters(np.asarray(rows).T[:, :, None], specification)
        return weighted_misfit(measurement, *model_backbone(parameters, measurement.amplitude, F0, ZETA0,
                                                            measurement.amplitude[-1]))
    return specification, residuals


def test_the_batched_jacobian_is_forward_differences_column_by_column():
    measurement, _ = virtual_measurement(TRUTH, seed=5)
    specification, residuals = residual_rows(measurement)
    vector = _to_vector({**JOINT, **TRUTH}, specification) + 0.05
    jacobian = forward_difference_jacobian(residuals, vector)
    step = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(vector)) * np.where(vector >= 0, 1.0, -1.0)
    step = (vector + step) - vector
    by_column = approx_fprime(vector, lambda v: residuals(v[None])[0], step)
    assert jacobian.shape == (2 * AMPLITUDES.size, len(specification))
    np.testing.assert_allclose(jacobian, by_column, rtol=1e-12, atol=1e-12 * np.max(np.abs(by_column)))
    # and against central differences of a larger step: the derivative itself, to the forward step's error
    central = np.column_stack([(residuals((vector + h)[None])[0] - residuals((vector - h)[None])[0]) / (2e-4)
                               for h in 1e-4 * np.eye(vector.size)])
    assert np.max(np.abs(jacobian - central)) < 1e-4 * np.max(np.abs(central))


def test_a_fit_with_it_reaches_the_optimum_of_scipys_two_point_jacobian():
    measurement, _ = virtual_measurement(TRUTH, seed=6)
    specification, residuals = residual_rows(measurement)
    start = _to_vector({**JOINT, **TRUTH}, specification) + 0.3
    chi_squared, vector, _, converged = best_least_squares(residuals, [start], {})
    scipys = least_squares(lambda v: residuals(v[None])[0], start, jac="2-point", method="trf", x_scale="jac",
                           max_nfev=400)
    assert converged and scipys.status > 0
    # the same step and difference quotient as scipy's: the same iterates, to rounding (here bit for bit)
    assert abs(chi_squared - float(np.sum(scipys.fun ** 2))) < 1e-10 * chi_squared
    np.testing.assert_allclose(vector, scipys.x, rtol=1e-10, atol=1e-12)
