"""The nominal low-amplitude frequency and damping estimated from a measurement (``discrepancy.nominal``).

Checked, on backbones of an Iwan joint's microslip regime (frequency fall and damping rise as q^0.96, chi = -0.04)
whose lowest levels are noise-dominated (stated uncertainty up to 40 times that of the upper levels):
- the estimate's stated standard errors cover the zero-amplitude values at their nominal rate over 200 noise draws
  (97 % at two standard errors), its mean error is well inside them, and its RMS error is a fifth or less of the
  lowest level's;
- one level far off its stated uncertainty moves it by less than half a standard error, and is named as left out;
- it never comes from one level: a lowest decade with one level takes the lowest four; three levels take all three;
- on a ring-down of the challenge set made by another generator (mass loading: the frequency 1.5 % down at every
  amplitude), through freevib, it finds the loaded frequency and the linear damping within two standard errors.
"""

import numpy as np

from discrepancy.nominal import MIN_LEVELS, low_amplitude_nominal
from locations import challenge_ringdown
from study.structures import BackboneLevels

F0, Z0 = 169.86, 1.666e-3  # zero-amplitude frequency (Hz) and linear damping


def iwan_measurement(seed=None, amplitude=np.geomspace(1.2e-6, 3e-4, 20), outlier=None):
    """Levels of an Iwan microslip backbone (-0.0094 % and +2.3 % of damping at 1e-6, growing as q^0.96) with
    noise of the stated uncertainty, which is noise-dominated at the lowest levels (up to 0.8 Hz, 55 % of zeta);
    ``outlier`` = (level, multiple of its stated uncertainty) shifts one level's frequency; seed None: no noise."""
    law = (amplitude / 1e-6) ** 0.96
    frequency, damping = F0 * (1 - 9.4e-5 * law), Z0 * (1 + 0.023 * law)
    sigma_f = 0.017 + 0.8 * (amplitude[0] / amplitude) ** 1.5
    sigma_z = 0.02 * damping + 0.9e-3 * (amplitude[0] / amplitude) ** 1.5
    if seed is not None:
        rng = np.random.default_rng(seed)
        frequency, damping = frequency + sigma_f * rng.normal(size=amplitude.size), damping + sigma_z * rng.normal(
            size=amplitude.size)
    if outlier is not None:
        frequency[outlier[0]] += outlier[1] * sigma_f[outlier[0]]
    return BackboneLevels(amplitude, frequency, damping, sigma_f, sigma_z, float(frequency[0]), "virtual", "Iwan law")


def test_stated_errors_cover_the_zero_amplitude_values_over_noise_draws():
    estimates = [low_amplitude_nominal(iwan_measurement(seed)) for seed in range(200)]
    f, sf, z, sz = (np.array([estimate[k] for estimate in estimates]) for k in range(4))
    covered_f, covered_z = np.mean(np.abs(f - F0) <= 2 * sf), np.mean(np.abs(z - Z0) <= 2 * sz)
    assert covered_f >= 0.9 and covered_z >= 0.9  # 95 % nominal; 0.9 is 3 binomial standard deviations below
    assert abs(np.mean(f - F0)) < 0.25 * np.mean(sf) and abs(np.mean(z - Z0)) < 0.25 * np.mean(sz)
    lowest = [iwan_measurement(seed) for seed in range(200)]
    for estimate, truth, name in ((f, F0, "frequency_hz"), (z, Z0, "damping")):
        alone = np.array([getattr(measurement, name)[0] for measurement in lowest])
        assert np.sqrt(np.mean((alone - truth) ** 2)) > 4 * np.sqrt(np.mean((estimate - truth) ** 2))


def test_one_level_far_off_its_uncertainty_does_not_move_the_nominal():
    clean = low_amplitude_nominal(iwan_measurement())
    shifted = low_amplitude_nominal(iwan_measurement(outlier=(5, 20.0)))
    assert abs(shifted.frequency_hz - clean.frequency_hz) < 0.5 * clean.frequency_standard_error_hz
    assert abs(clean.frequency_hz - F0) < 0.1 * clean.frequency_standard_error_hz  # the line's bias on q^0.96
    assert "left out the level at" in shifted.source and "left out" not in clean.source


def test_never_from_one_level():
    sparse = iwan_measurement(amplitude=np.array([1.2e-6, 2e-5, 3e-5, 5e-5, 8e-5, 1.3e-4]))
    estimate = low_amplitude_nominal(sparse)
    assert f"through its {MIN_LEVELS} lowest levels" in estimate.source
    assert abs(estimate.frequency_hz - F0) < 2 * estimate.frequency_standard_error_hz
    three = low_amplitude_nominal(iwan_measurement(amplitude=np.array([1.2e-6, 2e-6, 4e-6])))
    assert "through its 3 lowest levels" in three.source and np.isfinite(three.frequency_standard_error_hz)


def test_challenge_ringdown_with_mass_loading_gives_the_loaded_nominal(tmp_path):
    """P2 of the challenge set: the reference joint (stuck 169.86148 Hz, zeta_0 1.666e-3) with the mass 1.5 %
    up; its nominal is 169.86148 / sqrt(1.015) Hz and 1.666e-3 (the lowest level alone reads 1 Hz off)."""
    from experiment.backbone_files import read_backbone
    from cli.console import main as surrogacy
    from study.structures import measured_levels

    ringdown = challenge_ringdown("P2", tmp_path)
    assert surrogacy(["freevib", str(ringdown), "--mode-hz", "170", "--out", str(tmp_path / "freevib")]) == 0
    measurement = measured_levels(read_backbone(tmp_path / "freevib" / "P2_mode_170Hz_backbone.csv"))
    estimate = low_amplitude_nominal(measurement)
    loaded = 169.86147864728014 / np.sqrt(1.015)
    assert abs(estimate.frequency_hz - loaded) < 2 * estimate.frequency_standard_error_hz < 1e-3 * loaded
    assert abs(estimate.damping - 1.666e-3) < 2 * estimate.damping_standard_error < 0.5 * 1.666e-3
    assert abs(measurement.frequency_hz[0] - loaded) > 5 * estimate.frequency_standard_error_hz
