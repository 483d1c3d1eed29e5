"""FreeVib's stated standard errors against its actual errors, on virtual decays whose backbone is known
(``discrepancy.virtual_data``: the reference joint, alone and with microslip, one hit of 4 s, 12 seeds), at three
levels of sensor noise: the root mean square of (error of the bin mean / stated standard error) over the whole
amplitude range lies between 0.7 and 1.4 for the natural frequency and the damping ratio.

The known natural frequency is the one FreeVib's Eq. 4 sees in the generator's decay: the slow-flow phase advances
at omega(a), so omega_n = omega(a) sqrt(1 + zeta(a)^2).
"""

import numpy as np
import pytest

from discrepancy.virtual_data import true_backbone, undeclared_ringdown
from experiment.backbone import binned_means, ringdown_backbone

SEEDS = range(12)


def normalised_errors(effects, noise_db, seed):
    """(error / stated standard error) of the Hilbert backbone's bin means of frequency and damping, (2, n_grid)."""
    backbone = ringdown_backbone(undeclared_ringdown(effects, seed=seed, noise_db=noise_db), 169.0, grid_points=15,
                                 seed=100 + seed)
    record, grid = backbone.records[0].hilbert, backbone.hilbert.amplitude
    fine = np.geomspace(record.amplitude.min() / 2, record.amplitude.max() * 2, 2000)
    frequency, damping = true_backbone(effects, amplitudes=fine)
    known = [binned_means(record.amplitude, np.interp(np.log(record.amplitude), np.log(fine), values), grid)
             for values in (frequency * np.sqrt(1 + damping ** 2), damping)]
    stated = backbone.hilbert
    return np.array([(stated.natural_frequency_hz - known[0]) / stated.natural_frequency_standard_error_hz,
                     (stated.damping_ratio - known[1]) / stated.damping_ratio_standard_error])


@pytest.mark.parametrize("effects", [(), ("microslip",)])
@pytest.mark.parametrize("noise_db", [40.0, 60.0, 80.0])
def test_stated_standard_errors_match_the_actual_errors(effects, noise_db):
    errors = np.array([normalised_errors(effects, noise_db, seed) for seed in SEEDS])
    rms = np.sqrt(np.nanmean(errors ** 2, axis=(0, 2)))
    assert np.all((0.7 < rms) & (rms < 1.4)), f"RMS of error / stated: frequency {rms[0]:.2f}, damping {rms[1]:.2f}"
