"""Ring-down readers and the ``surrogacy freevib`` command: units, layouts, and clear errors on bad input.

Physics checked: the same decay written as CSV (mm), MATLAB (g) and UFF 58 (m/s^2) reads back in SI units and
gives one backbone; several hits average; every bad input (NaN samples, time running backwards, a unit that
is not a motion, a record shorter than the mode needs, a signal that does not decay) is refused with a
ValueError naming the file, the field and the problem, and the command prints it on one line with status 2.
"""

import csv
import math

import numpy as np
import pyuff
import pytest
import scipy.io

from experiment.backbone import ringdown_backbone
from experiment.ringdown import RingDown, RingDownError
from experiment.measured_files import MeasuredFileError, read_ringdown
from experiment.ringdown_files import (STANDARD_GRAVITY, write_ringdown_csv, write_ringdown_mat,
                                       write_ringdown_uff58)
from cli.console import main

SAMPLE_RATE = 2000.0  # Hz
FREQUENCY_HZ, DAMPING_RATIO = 50.0, 2e-3


def acceleration_decay(time, level=1.0):
    """Acceleration (m/s^2) of a linear decay of the 50 Hz mode, unit displacement amplitude times level."""
    omega = 2 * np.pi * FREQUENCY_HZ
    return -level * omega**2 * np.exp(-DAMPING_RATIO * omega * time) * np.cos(omega * time)


def write_csv(path, columns, rows):
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(rows)
    return path


@pytest.fixture
def time():
    return np.arange(0, 2.0, 1 / SAMPLE_RATE)


def test_csv_with_hits_and_units_reads_in_si(tmp_path, time):
    rows = [(hit, t, 1e3 * a, 1e3 * 0.5 * a) for hit, level in ((1, 1.0), (2, 0.6))
            for t, a in zip(time, acceleration_decay(time, level))]
    path = write_csv(tmp_path / "hits.csv", ["hit", "time [s]", "tip [mm/s^2]", "mid [mm/s^2]"], rows)
    hits = read_ringdown(path)
    assert [hit.hit for hit in hits] == ["hit 1", "hit 2"]
    assert hits[0].channels == ("tip", "mid") and hits[0].quantity == "acceleration"
    np.testing.assert_allclose(hits[1].signals[0], acceleration_decay(time, 0.6), rtol=1e-12)
    assert hits[0].sample_rate == pytest.approx(SAMPLE_RATE)


def test_mat_struct_in_g_with_hit_columns(tmp_path, time):
    hits = np.column_stack([acceleration_decay(time), acceleration_decay(time, 0.5)]) / STANDARD_GRAVITY
    path = tmp_path / "hammer.mat"
    scipy.io.savemat(path, {"HIdata": {"time": time, "acc1": hits, "units": "s, g"}})
    records = read_ringdown(path)
    assert len(records) == 2 and records[0].channels == ("acc1",)
    np.testing.assert_allclose(records[1].signals[0], acceleration_decay(time, 0.5), rtol=1e-12)


def test_uff58_load_cases_are_hits(tmp_path, time):
    datasets = [pyuff.prepare_58(func_type=1, load_case_id=hit, rsp_node=node, rsp_dir=3, ref_node=1, ref_dir=3,
                                 x=time, data=acceleration_decay(time, level) * node, id1=f"hit {hit}",
                                 abscissa_spacing=1, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
                                 ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2",
                                 orddenom_spec_data_type=0, z_axis_spec_data_type=0, binary=0)
                for hit, level in ((1, 1.0), (2, 0.8)) for node in (1, 2)]
    path = tmp_path / "ringdown.uff"
    pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
    records = read_ringdown(path)
    assert len(records) == 2 and records[0].channels == ("node 1 dir 3", "node 2 dir 3")
    np.testing.assert_allclose(records[1].signals[1], 2 * acceleration_decay(time, 0.8), rtol=1e-6)


def test_backbone_of_several_hits_is_the_linear_mode(tmp_path, time):
    rows = [(hit, t, a) for hit, level in ((1, 1.0), (2, 0.8), (3, 0.65))
            for t, a in zip(time, acceleration_decay(time, level))]
    path = write_csv(tmp_path / "hits.csv", ["hit", "time [s]", "tip [m/s^2]"], rows)
    backbone = ringdown_backbone(read_ringdown(path), FREQUENCY_HZ, grid_points=12)
    seen = backbone.hilbert.n_records == 3
    assert np.count_nonzero(seen) >= 3
    assert np.max(np.abs(backbone.hilbert.natural_frequency_hz[seen] / FREQUENCY_HZ - 1)) < 1e-3
    assert np.max(np.abs(backbone.hilbert.damping_ratio[seen] / DAMPING_RATIO - 1)) < 0.02
    # displacement amplitude: acceleration / omega^2, so the top of the grid is below the unit release amplitude
    assert backbone.hilbert.amplitude[-1] < 1.0 and backbone.amplitude_unit == "m"


def assert_names(error, path, field, problem):
    message = str(error.value)
    assert isinstance(error.value, ValueError)
    assert path.name in message and f"'{field}'" in message and problem in message


def test_nan_samples_are_refused(tmp_path, time):
    signal = acceleration_decay(time)
    signal[100] = np.nan
    path = write_csv(tmp_path / "nan.csv", ["time [s]", "tip [m/s^2]"], zip(time, signal))
    with pytest.raises(RingDownError) as error:
        read_ringdown(path)
    assert_names(error, path, "tip", "NaN")


def test_time_running_backwards_is_refused(tmp_path, time):
    backwards = time.copy()
    backwards[[50, 51]] = backwards[[51, 50]]
    path = tmp_path / "backwards.mat"
    scipy.io.savemat(path, {"time": backwards, "acc": acceleration_decay(time), "units": "s, m/s^2"})
    with pytest.raises(RingDownError) as error:
        read_ringdown(path)
    assert_names(error, path, "time", "not strictly increasing")


@pytest.mark.parametrize("unit", ["N", "V", "m/s^3"])
def test_unit_that_is_not_a_motion_is_refused(tmp_path, time, unit):
    path = write_csv(tmp_path / "force.csv", ["time [s]", f"tip [{unit}]"], zip(time, acceleration_decay(time)))
    with pytest.raises(RingDownError) as error:
        read_ringdown(path)
    assert_names(error, path, "tip", f"unit '{unit}'")


def test_uff_units_contradicting_the_data_type_are_refused(tmp_path, time):
    dataset = pyuff.prepare_58(func_type=1, load_case_id=1, rsp_node=4, rsp_dir=3, ref_node=1, ref_dir=3, x=time,
                               data=acceleration_decay(time), abscissa_spacing=1, abscissa_spec_data_type=17,
                               abscissa_axis_units_lab="s", ordinate_spec_data_type=12,
                               ordinate_axis_units_lab="mm", orddenom_spec_data_type=0, z_axis_spec_data_type=0,
                               binary=0)
    path = tmp_path / "mislabelled.uff"
    pyuff.UFF(str(path)).write_sets([dataset], mode="overwrite")
    with pytest.raises(RingDownError) as error:
        read_ringdown(path)
    assert_names(error, path, "node 4 dir 3", "contradict")


def test_record_too_short_for_the_mode_is_refused(tmp_path):
    short = np.arange(0, 0.3, 1 / SAMPLE_RATE)  # 15 periods of the 50 Hz mode
    path = write_csv(tmp_path / "short.csv", ["time [s]", "tip [m/s^2]"], zip(short, acceleration_decay(short)))
    with pytest.raises(RingDownError) as error:
        ringdown_backbone(read_ringdown(path), FREQUENCY_HZ)
    assert_names(error, path, "hit 1: modal", "too short")


def test_signal_without_decay_is_refused(tmp_path, time):
    steady = np.cos(2 * np.pi * FREQUENCY_HZ * time)
    path = write_csv(tmp_path / "steady.csv", ["time [s]", "tip [m]"], zip(time, steady))
    with pytest.raises(RingDownError) as error:
        ringdown_backbone(read_ringdown(path), FREQUENCY_HZ)
    assert_names(error, path, "hit 1: modal", "no decay")


def test_command_writes_csv_plot_and_sidecar(tmp_path, time):
    path = write_csv(tmp_path / "hit.csv", ["time [s]", "tip [m/s^2]", "root [m/s^2]"],
                     zip(time, acceleration_decay(time), 0.3 * acceleration_decay(time)))
    out = tmp_path / "out"
    assert main(["freevib", str(path), "--mode-hz", "50", "--per-channel", "--out", str(out)]) == 0
    table = np.genfromtxt(out / "hit_mode_50Hz.csv", delimiter=",", names=True)
    header = (out / "hit_mode_50Hz.csv").read_text().splitlines()[0]
    assert "amplitude [m]" in header and "natural_frequency_hilbert [Hz]" in header
    seen = table["records_"] == 2
    assert np.max(np.abs(table["natural_frequency_hilbert_Hz"][seen] / FREQUENCY_HZ - 1)) < 1e-3
    assert (out / "hit_mode_50Hz.png").read_bytes()[:4] == b"\x89PNG"
    assert "source_sha256" in (out / "hit_mode_50Hz.json").read_text()


def test_command_reports_bad_input_on_one_line(tmp_path, time, capsys):
    path = write_csv(tmp_path / "force.csv", ["time [s]", "tip [N]"], zip(time, acceleration_decay(time)))
    assert main(["freevib", str(path), "--mode-hz", "50", "--out", str(tmp_path / "out")]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "force.csv" in message and "'tip'" in message
    assert not (tmp_path / "out").exists()


def test_command_separates_close_modes_with_given_shapes(tmp_path, time):
    """Two sensors, modes at 50 and 52 Hz: --mode-shapes with --mode-index 2 extracts the 52 Hz mode."""
    omega = 2 * np.pi * np.array([50.0, 52.0])
    modal = np.exp(-3e-3 * omega[:, None] * time) * np.cos(omega[:, None] * time + np.array([[0.0], [1.3]]))
    shapes = np.array([[1.0, 0.7], [0.5, -1.0]])
    path = write_csv(tmp_path / "two_modes.csv", ["time [s]", "a [m]", "b [m]"], zip(time, *(shapes @ modal)))
    np.savetxt(tmp_path / "shapes.csv", shapes, delimiter=",")
    out = tmp_path / "out"
    assert main(["freevib", str(path), "--mode-hz", "52", "--mode-shapes", str(tmp_path / "shapes.csv"),
                 "--mode-index", "2", "--out", str(out)]) == 0
    table = np.genfromtxt(out / "two_modes_mode_52Hz.csv", delimiter=",", names=True)
    seen = np.isfinite(table["natural_frequency_hilbert_Hz"])
    assert np.max(np.abs(table["natural_frequency_hilbert_Hz"][seen] / 52.0 - 1)) < 1e-3
    assert np.max(np.abs(table["damping_ratio_hilbert_"][seen] / 3e-3 - 1)) < 0.02


def test_unknown_channel_is_refused(tmp_path, time):
    path = write_csv(tmp_path / "hit.csv", ["time [s]", "tip [m/s^2]"], zip(time, acceleration_decay(time)))
    with pytest.raises(RingDownError) as error:
        ringdown_backbone(read_ringdown(path), FREQUENCY_HZ, channels=["root"])
    assert_names(error, path, "root", "no such channel")


@pytest.mark.parametrize("suffix, rtol", [(".csv", 0.0), (".mat", 0.0), (".uff", 1e-6)])
def test_written_ring_downs_read_back(tmp_path, time, suffix, rtol):
    """Two hits of two channels written by the writer of each format read back with their times and signals
    (UFF 58 ASCII keeps about 12 digits)."""
    hits = [RingDown(time, np.array([acceleration_decay(time, level), 0.5 * acceleration_decay(time, level)]),
                     ("tip", "root"), "acceleration", "synthetic", f"hit {k + 1}")
            for k, level in enumerate((1.0, 0.7))]
    writer = {".csv": write_ringdown_csv, ".mat": write_ringdown_mat, ".uff": write_ringdown_uff58}[suffix]
    writer(hits, tmp_path / f"hits{suffix}")
    records = read_ringdown(tmp_path / f"hits{suffix}")
    assert len(records) == 2 and all(record.quantity == "acceleration" for record in records)
    for record, hit in zip(records, hits):
        np.testing.assert_allclose(record.time, hit.time, rtol=rtol)
        np.testing.assert_allclose(record.signals, hit.signals, rtol=rtol)


def bad_ring_down(tmp_path, time, kind: str):
    """A ring-down file that cannot be analysed, and (field, problem) of its refusal."""
    if kind == "all channels zero":
        return (write_csv(tmp_path / "zero.csv", ["time [s]", "tip [m/s^2]", "root [m/s^2]"],
                          zip(time, 0 * time, 0 * time)), "hit 1", "all channels are zero (tip, root)")
    if kind == "header only":
        return write_csv(tmp_path / "header.csv", ["time [s]", "tip [m/s^2]"], []), "samples", "no sample rows"
    if kind == "complex channel":
        path = tmp_path / "complex.mat"
        scipy.io.savemat(path, {"time": time, "units": "s, m/s^2", "tip": acceleration_decay(time),
                                "root": acceleration_decay(time) * (1 + 0.1j)})
        return path, "root", "complex values; expected real samples"
    (tmp_path / "folder.csv").mkdir()
    return tmp_path / "folder.csv", "file", "a folder; expected a measured file: backbone CSV (.csv)"


BAD_RING_DOWNS = ["all channels zero", "header only", "complex channel", "a folder"]


@pytest.mark.parametrize("kind", BAD_RING_DOWNS)
def test_ring_down_that_cannot_be_analysed_is_named_for_what_it_is(tmp_path, time, kind):
    """Channels that are all zero were reported as "no decay", a header without samples as a header count
    mismatch (with numpy's warning), a complex channel was dropped without a word, a folder "does not exist"."""
    path, field, problem = bad_ring_down(tmp_path, time, kind)
    with pytest.raises((RingDownError, MeasuredFileError)) as error:  # the registry names a file of no format
        ringdown_backbone(read_ringdown(path), FREQUENCY_HZ)
    assert_names(error, path, field, problem)


@pytest.mark.parametrize("kind", BAD_RING_DOWNS)
def test_command_names_a_ring_down_that_cannot_be_analysed_on_one_line(tmp_path, time, capsys, kind):
    path, field, problem = bad_ring_down(tmp_path, time, kind)
    assert main(["freevib", str(path), "--mode-hz", "50", "--out", str(tmp_path / "out")]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and f"{path}: field '{field}': {problem}" in message
    assert not (tmp_path / "out").exists()


def test_freevib_refuses_a_ring_down_without_a_decay(tmp_path, capsys):
    """A steady sine (no free decay) given to ``surrogacy freevib``: exit 2, one line naming the file and the
    missing decay, nothing written."""
    time = np.arange(0, 2.0, 1 / 4096).tolist()
    path = tmp_path / "steady.csv"
    path.write_text("time [s],sensor [m]\n" + "\n".join(f"{t!r},{1e-5 * math.sin(2 * math.pi * 169 * t)!r}"
                                                        for t in time) + "\n")
    out = tmp_path / "out"
    assert main(["freevib", str(path), "--mode-hz", "169", "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert str(path) in error and "deca" in error
    assert not out.exists()
