"""FreeVib's stated standard errors against its actual errors, on virtual decays whose backbone is known
(``discrepancy.virtual_data``: the reference joint, alone and with microslip, one hit of 4 s, 12 seeds), at three
levels of sensor noise: the root mean square of (error / stated standard error) over the whole amplitude range lies
between 0.7 and 1.4 for the natural frequency and the damping ratio. The error is against the known backbone at each
grid amplitude, where the backbone says its point is (the ends of the range included), at every grid point that
the grid resolves: where the averaging (``experiment.backbone.values_at_grid``) of the known backbone itself, at
the decay's own amplitudes, gives it at the grid point to within the stated standard error. A kink inside a bin
(the reference joint's onset of macroslip, where its damping jumps fourfold within one bin) is finer than that.

The known natural frequency is the one FreeVib's Eq. 4 sees in the generator's decay: the slow-flow phase advances
at omega(a), so omega_n = omega(a) sqrt(1 + zeta(a)^2).
"""

import numpy as np
import pytest

from discrepancy.virtual_data import true_backbone, undeclared_ringdown
from experiment.backbone import ringdown_backbone, values_at_grid

SEEDS = range(12)


def normalised_errors(effects, noise_db, seed):
    """(error / stated standard error) of the Hilbert backbone's frequency and damping at its grid amplitudes,
    (2, n_grid), NaN where the grid does not resolve the known backbone (module docstring)."""
    backbone = ringdown_backbone(undeclared_ringdown(effects, seed=seed, noise_db=noise_db), 169.0, grid_points=15,
                                 seed=100 + seed)
    stated, samples = backbone.hilbert, backbone.records[0].hilbert.amplitude
    grid = stated.amplitude
    errors = []
    for estimate, error, known in ((stated.natural_frequency_hz, stated.natural_frequency_standard_error_hz,
                                    lambda a: natural_frequency(*true_backbone(effects, amplitudes=a))),
                                   (stated.damping_ratio, stated.damping_ratio_standard_error,
                                    lambda a: true_backbone(effects, amplitudes=a)[1])):
        averaged = values_at_grid([samples], [known(samples)], grid)[0]
        resolved = np.abs(averaged - known(grid)) <= error
        errors.append(np.where(resolved, (estimate - known(grid)) / error, np.nan))
    return np.array(errors)


def natural_frequency(frequency, damping):
    """The natural frequency FreeVib's Eq. 4 sees in the generator's decay (module docstring), Hz."""
    return frequency * np.sqrt(1 + damping ** 2)


@pytest.mark.parametrize("effects", [(), ("microslip",)])
@pytest.mark.parametrize("noise_db", [40.0, 60.0, 80.0])
def test_stated_standard_errors_match_the_actual_errors(effects, noise_db):
    errors = np.array([normalised_errors(effects, noise_db, seed) for seed in SEEDS])
    rms = np.sqrt(np.nanmean(errors ** 2, axis=(0, 2)))
    assert np.all((0.7 < rms) & (rms < 1.4)), f"RMS of error / stated: frequency {rms[0]:.2f}, damping {rms[1]:.2f}"
    resolved = np.isfinite(errors).mean(axis=(0, 2))
    assert np.all(resolved > 0.85), f"share of grid points resolved: {resolved}"
