"""Virtual experiments of the Brake-Reuss beams: the reference joint, hammer ring-downs processed as a measurement.

Physics checked: the reference joint makes the BRB's stuck first bending mode the measured 169.48 Hz (paper Table
1) inside Table 3's limits; a hammer test of the BRB, processed by the measurement's own path (modal filter,
band-pass, FreeVib, mean over hits), softens by 1-3 % over its amplitudes while its damping rises to several
times Table 1's linear value; and it follows QSMA of the same design (an independent method: harmonic balance of
the backbone, no time integration, no other modes) once Newmark's known period error is taken out.

Measured with the default test (7 hits, 70 periods, 50 samples per period; about 60 s per beam): BRB from 1.6e-5
to 1.9e-4 m kg^0.5, 168.70 -> 166.75 Hz, damping 2.56e-3 -> 6.8e-3 (4.1 times Table 1's); LBRB 80.49 -> 79.72 Hz,
SBRB 91.77 -> 91.47 Hz (the same joint, hit to the same modal amplitude, slips less in these beams). Hilbert frequency 0.124-0.160 % below QSMA: Newmark's period error
(omega dt)^2 / 12 = 0.132 % plus at most 0.028 %; damping 0.1-5.6 % above QSMA, growing with amplitude (the hit
also rings the other modes, whose joint motion adds slip that QSMA's single-mode backbone does not see).
"""

import json

import numpy as np
import pytest

from experiment.backbone_files import read_backbone
from locations import REPOSITORY
from nonlinear.joint import parameter_names
from nonlinear.qsma_vectorised import qsma_designs
from pipeline.files import sha256_file
from pipeline.runners import process_pool
from reduction.superelement import stuck_joint_modes
from geometry.parameters import BEAM_NAMES
from virtual_experiment.hammer_test import (HammerTest, hammer_hits, low_amplitude_table,
                                            virtual_experiment, virtual_experiments, write_virtual_experiment)
from pipeline.published import TABLE1
from virtual_experiment.reference_joint import beam_space, outside_limits, reference_joint, stuck_frequency_hz

ROM = REPOSITORY / "build" / "rom"  # built by the beam_roms fixture (conftest)
# Two hits of the default test's hardest ones: 0.64 and 1.6 N s nominal, 5e-5 to 2.5e-4 m kg^0.5 (about 20 s).
SHORT_TEST = HammerTest(n_hits=2, impulse_range=2.5)
# One coarse hit, enough for FreeVib (50 periods, 20 samples per period; about 3 s): files and seeds.
TINY_TEST = HammerTest(n_hits=1, periods=50, samples_per_period=20)
FREQUENCY_TOLERANCE = 5e-4  # relative, after Newmark's period error: measured 2.8e-4 at most
# The LBRB's hardest hits ring its neighbouring modes (tied 85.8 and 99.7 Hz) whose joint motion adds slip that
# QSMA's single-mode backbone does not see: its hammer backbone lies up to 1.3e-3 below QSMA at the top, while the
# same transient started in the mode's shape agrees within 2.6e-4 (test_lbrb_single_mode_start_follows_qsma).
# and its damping up to 31 % above (extra slip, extra dissipation), while the single-mode start is within 10 %.
MULTI_MODE_TOLERANCE = 1.5e-3
MULTI_MODE_DAMPING_TOLERANCE = 0.35
DAMPING_TOLERANCE = 0.10  # relative: measured 8.4 % at most (other modes' slip, growing with amplitude; as in
# test_transient's hammer ring-down of the ASB)


def newmark_period_error(test: HammerTest) -> float:
    """Relative lengthening of the period by the average-acceleration rule at the test's step, (omega dt)^2 / 12."""
    return (2 * np.pi / test.samples_per_period) ** 2 / 12


@pytest.fixture(scope="module")
def table1():
    return TABLE1


@pytest.fixture(scope="module")
def brb(table1, beam_roms):
    """The BRB's joint space tracking its first bending mode and the reference joint tuned on it."""
    space = beam_space(ROM / "BRB.npz", table1["BRB"].frequency_hz)
    return space, reference_joint(space, table1["BRB"].frequency_hz)


@pytest.fixture(scope="module")
def short_brb_experiment(brb, table1):
    space, design = brb
    return virtual_experiment(space, "BRB", design, table1["BRB"].damping, table1["BRB"].frequency_hz, SHORT_TEST)


@pytest.fixture(scope="module")
def tiny_brb_experiment(brb, table1):
    space, design = brb
    return virtual_experiment(space, "BRB", design, table1["BRB"].damping, table1["BRB"].frequency_hz, TINY_TEST)


def test_reference_joint_gives_the_measured_brb_frequency(brb, table1):
    """Stuck at 169.48 Hz within 0.01 Hz, below the 182.84 Hz of the tied joint (a compliant joint), inside Table 3."""
    space, design = brb
    assert stuck_frequency_hz(space, design) == pytest.approx(table1["BRB"].frequency_hz, abs=0.01)
    assert stuck_frequency_hz(space, design) < stuck_joint_modes(space.superelement)[0][0]
    assert outside_limits(design, parameter_names("iwan4", 3)) == []


def test_reference_joint_softens_two_percent_and_damps_over_the_experiment(brb, table1):
    """QSMA of the reference joint in the BRB over the default test's amplitudes (1.6e-5 to 2.5e-4 m kg^0.5): near
    linear at the bottom (less than 0.4 % softer, damping below twice Table 1's), about 2 % softer at the top with
    the damping at four times Table 1's or more (paper section 3: 'approximately 2 %', 'large increase')."""
    space, design = brb
    zeta_0 = table1["BRB"].damping
    qsma = qsma_designs(space, "iwan4", design[None, :], amplitudes=[1.6e-5, 2.5e-4], linear_damping=zeta_0)
    assert qsma.converged.all()
    drop = 1 - qsma.frequency[0] / qsma.stuck_frequency[0]
    assert drop[0] < 4e-3 and qsma.damping[0, 0] < 2 * zeta_0
    assert 0.015 <= drop[1] <= 0.025 and qsma.damping[0, 1] >= 4 * zeta_0


def test_virtual_brb_softens_and_damps_like_the_measurement(short_brb_experiment, table1):
    """Frequency drop over the backbone's amplitudes 1-3 %, damping at its top at least twice Table 1's."""
    assert not short_brb_experiment.records.unconverged_steps.any()
    backbone = short_brb_experiment.backbone.backbone
    finite = np.isfinite(backbone.natural_frequency_hz)
    frequency, damping = backbone.natural_frequency_hz[finite], backbone.damping_ratio[finite]
    assert 0.01 <= 1 - frequency[-1] / frequency[0] <= 0.03
    assert damping[-1] >= 2 * table1["BRB"].damping
    assert np.all(np.diff(frequency) < 0) and damping[-1] > damping[0]


def test_virtual_brb_follows_qsma_of_the_same_joint(brb, short_brb_experiment, table1):
    """At the backbone's amplitudes, with the same linear damping: the Hilbert frequency is QSMA's shortened by
    Newmark's period error (0.13 % at 50 samples per period) within 0.05 %, the damping within 10 %."""
    space, design = brb
    backbone = short_brb_experiment.backbone.backbone
    finite = np.isfinite(backbone.natural_frequency_hz)
    qsma = qsma_designs(space, "iwan4", design[None, :], amplitudes=backbone.amplitude[finite],
                        linear_damping=table1["BRB"].damping)
    assert qsma.converged.all()
    expected = qsma.frequency[0] / (2 * np.pi) * (1 - newmark_period_error(SHORT_TEST))
    np.testing.assert_allclose(backbone.natural_frequency_hz[finite], expected, rtol=FREQUENCY_TOLERANCE)
    np.testing.assert_allclose(backbone.damping_ratio[finite], qsma.damping[0], rtol=DAMPING_TOLERANCE)


def test_written_backbone_says_virtual_and_reads_back_the_same_floats(tiny_brb_experiment, tmp_path):
    paths = write_virtual_experiment(tmp_path, tiny_brb_experiment, ROM / "BRB.npz")
    assert "# provenance: virtual" in paths["backbone"].read_text().splitlines()
    read = read_backbone(paths["backbone"])
    written = tiny_brb_experiment.backbone
    assert (read.structure, read.provenance, read.amplitude_unit) == ("BRB", "virtual", "m kg^0.5")
    assert read.low_amplitude_frequency_hz == written.low_amplitude_frequency_hz
    for name in ("amplitude", "natural_frequency_hz", "natural_frequency_spread_hz", "damping_ratio",
                 "damping_ratio_standard_error", "n_records"):
        np.testing.assert_array_equal(getattr(read.backbone, name), getattr(written.backbone, name))
    configuration = json.loads(paths["configuration"].read_text())
    assert configuration["provenance"] == "virtual"
    assert configuration["parameter_names"] == parameter_names("iwan4", 3)
    assert configuration["design"] == tiny_brb_experiment.configuration["design"]
    assert configuration["superelement"]["sha256"] == sha256_file(ROM / "BRB.npz")
    assert configuration["seed"] == TINY_TEST.seed
    assert configuration["hammer"]["impulses_Ns"] == tiny_brb_experiment.records.impulses.tolist()
    assert paths["ring_downs"].exists()


def test_same_seed_gives_the_same_backbone_and_another_seed_other_noise(brb, table1, tiny_brb_experiment):
    space, design = brb
    again = virtual_experiment(space, "BRB", design, table1["BRB"].damping, table1["BRB"].frequency_hz, TINY_TEST)
    np.testing.assert_array_equal(again.backbone.backbone.natural_frequency_hz,
                                  tiny_brb_experiment.backbone.backbone.natural_frequency_hz)
    np.testing.assert_array_equal(again.backbone.backbone.damping_ratio,
                                  tiny_brb_experiment.backbone.backbone.damping_ratio)
    other = virtual_experiment(space, "BRB", design, table1["BRB"].damping, table1["BRB"].frequency_hz,
                               HammerTest(n_hits=1, periods=50, samples_per_period=20, seed=TINY_TEST.seed + 1))
    assert not np.array_equal(other.records.hits[0].signals, tiny_brb_experiment.records.hits[0].signals)


def test_hits_on_worker_processes_are_the_same_bits_as_in_one_process(brb, table1):
    """Two short coarse hits (about 12 s): on two spawned worker processes (as the study runs them) the noisy records
    equal those simulated in this process bit for bit, in order (the noise is drawn here, hit by hit)."""
    space, design = brb
    test = HammerTest(n_hits=2, impulse_range=3.0, periods=20, samples_per_period=20)
    arguments = (space, "BRB", design, table1["BRB"].damping, table1["BRB"].frequency_hz, test)
    serial = hammer_hits(*arguments)
    with process_pool(2) as runner:
        parallel = hammer_hits(*arguments, runner=runner)
    for one, other in zip(serial.hits, parallel.hits, strict=True):
        assert one.hit == other.hit
        np.testing.assert_array_equal(one.signals, other.signals)
    np.testing.assert_array_equal(serial.noise_levels, parallel.noise_levels)
    np.testing.assert_array_equal(serial.unconverged_steps, parallel.unconverged_steps)


def test_low_amplitude_table_compares_with_table1(tiny_brb_experiment, table1):
    """The BRB's virtual low-amplitude frequency lies within 0.5 % of Table 1's (its stuck frequency is Table 1's;
    the backbone's lowest amplitude is slightly softer and Newmark's error at 20 samples per period is 0.8 %)."""
    (row,) = low_amplitude_table({"BRB": tiny_brb_experiment}, table1)
    assert row["table1_hz"] == table1["BRB"].frequency_hz
    assert row["difference_percent"] == pytest.approx(100 * (row["virtual_hz"] / row["table1_hz"] - 1))
    assert -1.5 < row["difference_percent"] < 0.0


@pytest.mark.slow
def test_three_beams_virtual_experiments(tmp_path, table1, beam_roms):
    """The demo's experiments (about 3 minutes): every beam's backbone is finite at every grid amplitude (a study
    reads it without gaps) and follows QSMA; the BRB spans 1-3 % of softening with the damping rising above
    four times Table 1's; the SBRB, stiffer at the joint for the same hammer, is the most linear (paper
    section 3)."""
    rows = virtual_experiments(ROM, tmp_path)
    assert [row["beam"] for row in rows] == list(BEAM_NAMES)
    drops = {}
    for beam in BEAM_NAMES:
        read = read_backbone(tmp_path / f"{beam}.csv")
        backbone = read.backbone
        assert np.all(np.isfinite(backbone.natural_frequency_hz)) and np.all(np.isfinite(backbone.damping_ratio))
        configuration = json.loads((tmp_path / f"{beam}_experiment.json").read_text())
        assert not any(configuration["unconverged_steps"])
        space = beam_space(ROM / f"{beam}.npz", table1[beam].frequency_hz)
        design = np.array(configuration["design"])
        qsma = qsma_designs(space, "iwan4", design[None, :], amplitudes=backbone.amplitude,
                            linear_damping=table1[beam].damping)
        expected = qsma.frequency[0] / (2 * np.pi) * (1 - newmark_period_error(HammerTest()))
        np.testing.assert_allclose(backbone.natural_frequency_hz, expected,
                                   rtol=MULTI_MODE_TOLERANCE if beam == "LBRB" else FREQUENCY_TOLERANCE)
        if beam == "LBRB":  # the other modes' slip only adds dissipation: above QSMA, by up to 31 % at the top
            assert np.all(backbone.damping_ratio >= (1 - DAMPING_TOLERANCE) * qsma.damping[0])
            np.testing.assert_allclose(backbone.damping_ratio, qsma.damping[0], rtol=MULTI_MODE_DAMPING_TOLERANCE)
        else:
            np.testing.assert_allclose(backbone.damping_ratio, qsma.damping[0], rtol=DAMPING_TOLERANCE)
        drops[beam] = 1 - backbone.natural_frequency_hz[-1] / backbone.natural_frequency_hz[0]
        if beam == "BRB":
            assert 0.01 <= drops[beam] <= 0.03
            assert backbone.damping_ratio[-1] >= 4 * table1[beam].damping
    assert drops["SBRB"] < min(drops["BRB"], drops["LBRB"])


@pytest.mark.slow
def test_lbrb_single_mode_start_follows_qsma(table1, beam_roms):
    """The LBRB's hammer backbone departs from QSMA by more than Newmark's error at large amplitude (frequency
    1.3e-3 below, damping 31 % above); the same transient started in the tracked mode's shape (no other mode rung)
    follows QSMA within FREQUENCY_TOLERANCE and DAMPING_TOLERANCE, so the departure is the other modes' slip, not
    the integrator or the estimator (about 20 s)."""
    from experiment.hilbert import freevib
    from nonlinear.transient import ring_down, sensor_modes

    design = reference_joint(beam_space(ROM / "BRB.npz", table1["BRB"].frequency_hz), table1["BRB"].frequency_hz)
    space = beam_space(ROM / "LBRB.npz", table1["LBRB"].frequency_hz)
    test = HammerTest()
    frequencies, shapes, target = sensor_modes(space, "iwan4", design)
    velocity = test.peak_modal_amplitude * frequencies[target]
    decay = ring_down(space, "iwan4", design, test.duration(table1["LBRB"].frequency_hz),
                      test.time_step(table1["LBRB"].frequency_hz), initial_modal_velocity=velocity,
                      linear_damping=table1["LBRB"].damping)
    estimate = freevib(decay.sensors.time, decay.modal_amplitude, frequencies[target] / (2 * np.pi))
    order = np.argsort(estimate.amplitude)
    amplitudes = np.geomspace(*np.percentile(estimate.amplitude, [20, 80]), 4)
    qsma = qsma_designs(space, "iwan4", design[None, :], amplitudes=amplitudes, linear_damping=table1["LBRB"].damping)
    expected = qsma.frequency[0] / (2 * np.pi) * (1 - newmark_period_error(test))
    measured = np.interp(amplitudes, estimate.amplitude[order], estimate.natural_frequency_hz[order])
    np.testing.assert_allclose(measured, expected, rtol=FREQUENCY_TOLERANCE)
    damping = np.interp(amplitudes, estimate.amplitude[order], estimate.damping_ratio[order])
    np.testing.assert_allclose(damping, qsma.damping[0], rtol=DAMPING_TOLERANCE)
