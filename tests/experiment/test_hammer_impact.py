"""Measured ring-down of a Brake-Reuss beam (Chen et al. 2022, HammerImpact.mat): first-mode backbone.

Physics checked: the three accelerometers see one modal decay, so their backbones (each channel divided by its
entry of the mode shape) agree far more closely than the amplitude dependence they resolve; the joint softens
and damps more with amplitude (paper section 3.1, Fig. 3); the sensor near a node sinks into its noise floor
first; the Hilbert and the cycle-by-cycle estimators agree within their stated uncertainty.
"""


import numpy as np
import pytest

from experiment.backbone import ringdown_backbone
from experiment.measured_files import read_ringdown
from locations import SHARED

DATA = SHARED / "data" / "chen2022-brb-hammer" / "HammerImpact.mat"
MODE_HZ = 80.5  # first spectral peak of all three channels (data README)

pytestmark = pytest.mark.skipif(not DATA.is_file(), reason=f"measured data not found at {DATA} "
                                                             "(shared/data beside the repository)")


@pytest.fixture(scope="module")
def per_channel():
    return ringdown_backbone(read_ringdown(DATA), MODE_HZ, per_channel=True)


def test_file_holds_three_accelerometers_at_12800_hz():
    (hit,) = read_ringdown(DATA)
    assert hit.channels == ("acc1", "acc2", "acc3") and hit.quantity == "acceleration"
    assert hit.sample_rate == pytest.approx(12800.0)


def test_channels_give_one_backbone(per_channel):
    backbone = per_channel.hilbert
    shared = backbone.n_records >= 2
    frequency_change = np.nanmax(backbone.natural_frequency_hz) - np.nanmin(backbone.natural_frequency_hz)
    assert np.count_nonzero(backbone.n_records == 3) >= 10
    assert np.max(backbone.natural_frequency_spread_hz[shared]) < 0.05 * frequency_change
    assert np.max(backbone.damping_ratio_spread[shared] / backbone.damping_ratio[shared]) < 0.10


def test_joint_softens_and_damps_more_with_amplitude(per_channel):
    backbone = per_channel.hilbert
    low, high = backbone.natural_frequency_hz[0], backbone.natural_frequency_hz[-1]
    assert low == pytest.approx(MODE_HZ, rel=0.005)
    assert 1e-3 < (low - high) / low < 2e-2  # softening of a fraction of a per cent (paper Fig. 3: up to 2 %)
    assert backbone.damping_ratio[-1] > 1.5 * backbone.damping_ratio[0]


def test_sensor_near_a_node_reaches_its_noise_floor_first(per_channel):
    lowest = {record.label.split(": ")[-1]: np.min(record.hilbert.amplitude) for record in per_channel.records}
    assert abs(per_channel.shape["acc2"]) < 0.1
    assert lowest["acc2"] > 3 * max(lowest["acc1"], lowest["acc3"])


def test_hilbert_and_cycle_estimators_agree_within_their_uncertainty(per_channel):
    """|difference| <= 2 combined standard uncertainties (channel spread and standard error, both estimators)."""
    hilbert, cycles = per_channel.hilbert, per_channel.cycles
    seen = np.isfinite(hilbert.natural_frequency_hz) & np.isfinite(cycles.natural_frequency_hz)
    assert np.count_nonzero(seen) == seen.size
    frequency_bound = 2 * np.hypot(hilbert.natural_frequency_uncertainty_hz, cycles.natural_frequency_uncertainty_hz)
    damping_bound = 2 * np.hypot(hilbert.damping_ratio_uncertainty, cycles.damping_ratio_uncertainty)
    assert np.all(np.abs(hilbert.natural_frequency_hz - cycles.natural_frequency_hz) <= frequency_bound)
    assert np.all(np.abs(hilbert.damping_ratio - cycles.damping_ratio) <= damping_bound)
    assert np.max(frequency_bound / hilbert.natural_frequency_hz) < 1e-3  # the check is sharp: below 0.1 %


@pytest.mark.parametrize("mode_hz", [190.0, 120.0, 60.0])
def test_a_band_without_the_mode_is_refused_not_estimated(mode_hz):
    """A guess whose band holds no decaying mode: the leakage of a neighbour (80.5 or 298 Hz) is not passed off as
    this band's mode; the error names the file, the record and the option."""
    from experiment.ringdown import RingDownError

    with pytest.raises(RingDownError, match=f"{DATA.name}.*outside the band.*--mode-hz"):
        ringdown_backbone(read_ringdown(DATA), mode_hz, per_channel=True)


def test_out_of_range_setting_is_named_before_any_signal_is_read():
    from experiment.backbone import BackboneSettingError

    with pytest.raises(BackboneSettingError, match="trim_periods = -5.0: expected a finite number of periods >= 0"):
        ringdown_backbone(read_ringdown(DATA), MODE_HZ, trim_periods=-5.0)
