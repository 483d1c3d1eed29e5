"""Backbone files: the documented CSV that studies read, and the measured ASB backbones.

Checked: a backbone extracted from ring-downs, labelled and written, reads back with the same floats and
labels; a malformed file (no rows, complex values) is refused naming the field; the measured ASB C1 backbone reads as a measured
mass-normalised backbone whose low-amplitude frequency and damping are those of the data README (about
93.7 Hz, 7.0e-4 to 7.7e-4 over 7e-6 to 1.1e-4 m kg^0.5) and survives the CSV round trip.
"""

import re

import numpy as np
import pytest

from experiment.backbone import ModeBackbone, mode_backbone, ringdown_backbone
from experiment.backbone_files import read_asb_backbone, read_backbone, write_backbone
from experiment.ringdown import RingDown
from locations import SHARED

ASB_BACKBONES = SHARED / "data" / "asb-backbones"
FREQUENCY_HZ, DAMPING_RATIO, SAMPLE_RATE = 50.0, 2e-3, 2000.0


def linear_hits(levels):
    """Displacement ring-downs (m) of a linear 50 Hz mode, one hit per release level."""
    time = np.arange(0, 2.0, 1 / SAMPLE_RATE)
    omega = 2 * np.pi * FREQUENCY_HZ
    decay = np.exp(-DAMPING_RATIO * omega * time) * np.cos(omega * time)
    return [RingDown(time, level * decay[None, :], ("tip",), "displacement", "synthetic", f"hit {k + 1}")
            for k, level in enumerate(levels)]


def assert_same_backbone(read: ModeBackbone, written: ModeBackbone):
    for name in ("structure", "low_amplitude_frequency_hz", "amplitude_unit", "provenance", "source"):
        assert getattr(read, name) == getattr(written, name)
    for name, value in vars(written.backbone).items():
        np.testing.assert_array_equal(getattr(read.backbone, name), value)


def test_backbone_round_trip_keeps_every_float(tmp_path):
    written = mode_backbone(ringdown_backbone(linear_hits([1.0, 0.8, 0.6]), FREQUENCY_HZ, grid_points=12),
                            "linear oscillator", "virtual")
    # FreeVib on a noise-free linear decay: 1.5e-6 measured at the smallest amplitude (Hilbert end effects)
    assert written.low_amplitude_frequency_hz == pytest.approx(FREQUENCY_HZ, rel=1e-5)
    assert np.isnan(written.backbone.natural_frequency_spread_hz).any()  # one record at the grid's ends
    write_backbone(written, tmp_path / "linear.csv")
    assert_same_backbone(read_backbone(tmp_path / "linear.csv"), written)


def test_header_json_lines_are_strict_json(tmp_path):
    """The settings, findings and dropped lines hold a NaN, an infinity and numpy scalars: written as strict JSON
    (null for the numbers that are not finite; RFC 8259 has no NaN), read back by a parser that refuses NaN."""
    import json
    from dataclasses import replace

    mode = mode_backbone(ringdown_backbone(linear_hits([1.0, 0.8]), FREQUENCY_HZ, grid_points=12), "oscillator",
                         "virtual", {"mode_hz": np.float64(50.0), "band": [np.nan, np.inf]},
                         {"checked": ["second_mode"], "found": [{"name": "second_mode", "outside_library": True,
                                                                 "summary": "s", "evidence": {"floor": np.nan}}]})
    mode = replace(mode, dropped=[{"amplitude": 1e-3, "natural_frequency_hz": np.nan, "damping_ratio": -np.inf,
                                   "records": np.int64(2), "reason": "r"}])
    write_backbone(mode, tmp_path / "strict.csv")
    header = {line[2:].partition(": ")[0]: line[2:].partition(": ")[2]
              for line in (tmp_path / "strict.csv").read_text().splitlines() if line.startswith("# ")}

    def refuse(constant):
        raise AssertionError(f"{constant} is not JSON")

    settings, findings, dropped = (json.loads(header[key], parse_constant=refuse)
                                   for key in ("settings", "findings", "dropped"))
    assert settings == {"mode_hz": 50.0, "band": [None, None]} and findings["found"][0]["evidence"] == {"floor": None}
    assert dropped == [{"amplitude": 1e-3, "natural_frequency_hz": None, "damping_ratio": None, "records": 2,
                        "reason": "r"}]
    read = read_backbone(tmp_path / "strict.csv")
    assert read.settings == settings and read.findings == findings and read.dropped == dropped


def test_backbone_file_without_provenance_is_refused(tmp_path):
    written = mode_backbone(ringdown_backbone(linear_hits([1.0]), FREQUENCY_HZ), "linear oscillator", "measured")
    write_backbone(written, tmp_path / "linear.csv")
    lines = (tmp_path / "linear.csv").read_text().splitlines()
    (tmp_path / "bad.csv").write_text("\n".join(line for line in lines if not line.startswith("# provenance")))
    with pytest.raises(ValueError, match="bad.csv: field 'provenance'"):
        read_backbone(tmp_path / "bad.csv")


def test_measured_asb_backbone_reads_and_round_trips(tmp_path):
    path = ASB_BACKBONES / "ASB_C1_20Nm_BB.mat"
    if not path.exists():
        pytest.skip(f"measured ASB backbone not available at {path} (shared data folder absent)")
    measured = read_asb_backbone(path)
    assert measured.structure == "ASB C1" and measured.provenance == "measured"
    assert measured.amplitude_unit == "m kg^0.5"
    assert measured.low_amplitude_frequency_hz == pytest.approx(93.7, abs=0.1)
    amplitude, damping = measured.backbone.amplitude, measured.backbone.damping_ratio
    assert np.all(np.diff(amplitude) >= 0) and amplitude[0] == pytest.approx(7e-6, rel=0.1)
    assert 6.5e-4 < np.median(damping[:100]) and np.median(damping[-100:]) < 8e-4
    write_backbone(measured, tmp_path / "asb_c1.csv")
    assert_same_backbone(read_backbone(tmp_path / "asb_c1.csv"), measured)


def test_backbone_csv_without_rows_and_complex_asb_vectors_are_refused(tmp_path):
    """A backbone CSV holding its header only, and an ASB backbone .mat with complex values, are refused naming
    the file and the field (numpy's warning and a silently dropped imaginary part before)."""
    import scipy.io

    asb_c1 = ASB_BACKBONES / "ASB_C1_20Nm_BB.mat"
    if not asb_c1.exists():
        pytest.skip(f"measured ASB backbone not available at {asb_c1} (shared data folder absent)")
    path = tmp_path / "X.csv"
    write_backbone(read_asb_backbone(asb_c1), path)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(line for line in lines if line.startswith("#") or line.startswith("modal")) + "\n")
    with pytest.raises(ValueError, match=re.escape(f"{path}: field 'rows': none below the header row")):
        read_backbone(path)
    contents = scipy.io.loadmat(asb_c1)
    complex_path = tmp_path / "ASB_C1_20Nm_BB.mat"
    scipy.io.savemat(complex_path, {"Q": contents["Q"], "W": contents["W"] * (1 + 1e-3j), "Z": contents["Z"]})
    with pytest.raises(ValueError, match=re.escape(f"{complex_path}: field 'W': complex values")):
        read_asb_backbone(complex_path)


def test_points_no_free_decay_gives_are_left_out_with_their_reason(tmp_path):
    """A FreeVib backbone of a 170 Hz mode band-passed to 119-221 Hz whose lowest point has a negative damping
    ratio (noise at the end of the decays) and whose top point lies at 230 Hz (outside the band-pass: leakage, not
    the mode): the written backbone holds the other points only, the two are listed with their cause, the
    low-amplitude frequency is that of the lowest point kept, and the study's levels read it without refusal."""
    from experiment.backbone import Backbone, RingDownBackbones, unphysical_points
    from study.structures import measured_levels

    amplitude = np.geomspace(1e-6, 1e-4, 8)
    frequency = 170.0 * (1 - 0.05 * amplitude / amplitude[-1])  # softening by 5 % over the range
    damping = 1.7e-3 * (1 + 3 * amplitude / amplitude[-1])
    frequency[-1], damping[0] = 230.0, -7e-4
    spread = np.full(8, 0.1)
    hilbert = Backbone(amplitude, frequency, spread, spread, damping, spread * 1e-3, spread * 1e-3, np.full(8, 7))
    measured = RingDownBackbones("ring.csv", 170.0, "m", {"acc1": 1.0}, [], hilbert, hilbert, (119.0, 221.0))
    assert sorted(unphysical_points(hilbert, (119.0, 221.0))) == [0, 7]
    written = mode_backbone(measured, "beam", "virtual")
    np.testing.assert_array_equal(written.backbone.amplitude, amplitude[1:7])
    assert written.low_amplitude_frequency_hz == frequency[1]
    assert [entry["amplitude"] for entry in written.dropped] == [amplitude[0], amplitude[7]]
    assert "damping ratio -0.0007 < 0" in written.dropped[0]["reason"]
    assert "230 Hz outside the band-pass 119-221 Hz" in written.dropped[1]["reason"]
    write_backbone(written, tmp_path / "beam.csv")
    read = read_backbone(tmp_path / "beam.csv")
    assert_same_backbone(read, written)
    assert read.dropped == written.dropped
    levels = measured_levels(read, 6, str(tmp_path / "beam.csv"))
    assert np.all(levels.damping > 0) and np.all((119.0 < levels.frequency_hz) & (levels.frequency_hz < 221.0))
