"""``surrogacy discrepancy``'s options and what it records of the nominal.

Checked: a nominal no linear mode has (a frequency not positive and finite, a damping ratio outside [0, 1) or not
finite), fewer levels than a measurement needs, and a nominal given with --study are each refused in one line that
names the option and what was expected, with exit status 2 and no output folder; a backbone holding a point no free
decay gives is refused naming the point and its cause (not a signal-check finding beside it), and so are a backbone
stating a provenance that is not one of the three and an empty file, naming the file; without the nominal
options the loop starts from the measurement's low-amplitude estimate, which discrepancy.json and .md state with
its standard errors and where it came from, and with what it cannot tell: an offset at every amplitude outside the
joint (a mass loading) is held by the estimate, which the verdict says.
"""

import json

import pytest

from discrepancy.virtual_data import REFERENCE_DAMPING, REFERENCE_FREQUENCY_HZ, write_undeclared_backbone
from cli.console import main as surrogacy


@pytest.mark.parametrize("option, value, expected", [
    ("--nominal-damping", "-0.01", "a finite damping ratio in [0, 1)"),
    ("--nominal-damping", "nan", "a finite damping ratio in [0, 1)"),
    ("--nominal-damping", "1", "a finite damping ratio in [0, 1)"),
    ("--nominal-frequency-hz", "-100", "a positive finite natural frequency in Hz"),
    ("--nominal-frequency-hz", "0", "a positive finite natural frequency in Hz"),
    ("--nominal-frequency-hz", "inf", "a positive finite natural frequency in Hz"),
    ("--levels", "0", "an integer >= 3"),
])
def test_an_option_out_of_range_is_refused_naming_it(tmp_path, capsys, option, value, expected):
    backbone = tmp_path / "measured.csv"
    write_undeclared_backbone(backbone)
    out = tmp_path / "out"
    assert surrogacy(["discrepancy", str(backbone), option, value, "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and f"option {option} = " in error and expected in error
    assert str(backbone) not in error and not out.exists()


def test_a_nominal_with_a_study_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert surrogacy(["discrepancy", "--study", str(tmp_path), "--structure", "ASB C1", "--nominal-damping", "1e-3",
                      "--out", str(out)]) == 2
    assert "option --nominal-damping applies to FILE" in capsys.readouterr().err and not out.exists()


def test_a_backbone_with_negative_damping_is_refused_naming_the_point(tmp_path, capsys):
    """A backbone written before freevib left such points out: its third point's damping set to -7e-4, and a
    second-mode finding beside it; the error names the point, its amplitude and the negative damping."""
    backbone = tmp_path / "measured.csv"
    write_undeclared_backbone(backbone)
    lines = backbone.read_text().splitlines()
    rows = [index for index, line in enumerate(lines) if line and line[0].isdigit()]
    values = lines[rows[2]].split(",")
    values[4] = "-0.0007"
    lines[rows[2]] = ",".join(values)
    finding = {"name": "second_mode", "outside_library": True, "summary": "a second mode", "evidence": {}}
    lines.insert(rows[0] - 1, "# findings: " + json.dumps({"checked": ["second_mode"], "found": [finding]}))
    backbone.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    assert surrogacy(["discrepancy", str(backbone), "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert f"{backbone}: point 3 of {len(rows)} (amplitude {float(values[0]):.4g}" in error
    assert "damping ratio -0.0007 < 0" in error and "second_mode" not in error and not out.exists()


def test_without_the_nominal_options_the_estimate_is_recorded_with_its_source(tmp_path):
    backbone = tmp_path / "measured.csv"
    write_undeclared_backbone(backbone)
    out = tmp_path / "out"
    assert surrogacy(["discrepancy", str(backbone), "--out", str(out)]) == 0
    record = json.loads((out / "discrepancy.json").read_text())
    assert record["nominal_source"].startswith("estimated from the measurement: weighted lines in amplitude")
    # the file's reference joint: stuck at REFERENCE_FREQUENCY_HZ with REFERENCE_DAMPING, noise 2e-4 f and 3 % zeta
    assert abs(record["nominal_frequency_hz"] - REFERENCE_FREQUENCY_HZ) < 3 * record[
        "nominal_frequency_standard_error_hz"] < 1e-3 * REFERENCE_FREQUENCY_HZ
    assert abs(record["nominal_damping"] - REFERENCE_DAMPING) < 3 * record[
        "nominal_damping_standard_error"] < 0.3 * REFERENCE_DAMPING
    report = (out / "discrepancy.md").read_text()
    assert f"Nominal of the reference model: f_0 = {record['nominal_frequency_hz']:.8g} +- " in report
    assert "estimated from the measurement" in report
    assert record["nominal_caveat"] in report and "stiffness_change" in record["nominal_caveat"]
    assert "linear_damping" in record["nominal_caveat"]


def test_an_offset_outside_the_joint_is_held_by_an_estimated_nominal_and_the_verdict_says_so(tmp_path, capsys):
    """A 1 % frequency drop at every amplitude (a mass loading, the project's generator): with the structure's
    nominal given, stiffness_change is named at its size; with the nominal estimated from the same file the offset
    is the estimate itself (the loaded frequency within three of its standard errors, the unloaded one far
    outside), stiffness_change is not named, and discrepancy.json, .md and the printed line say that an offset at
    every amplitude cannot be told from an estimated nominal; with the frequency given and the damping estimated,
    only linear_damping is said to be untested."""
    backbone = tmp_path / "loaded.csv"
    write_undeclared_backbone(backbone, ("stiffness_change",))
    loaded = REFERENCE_FREQUENCY_HZ * 0.99
    given = tmp_path / "given"
    assert surrogacy(["discrepancy", str(backbone), "--nominal-frequency-hz", str(REFERENCE_FREQUENCY_HZ),
                      "--nominal-damping", str(REFERENCE_DAMPING), "--out", str(given)]) == 0
    record = json.loads((given / "discrepancy.json").read_text())
    assert record["added"] == ["stiffness_change"] and record["nominal_caveat"] is None
    assert record["final_model"]["parameters"]["frequency_shift"] == pytest.approx(-0.01, rel=0.1)
    assert "holds any offset" not in capsys.readouterr().out
    estimated = tmp_path / "estimated"
    assert surrogacy(["discrepancy", str(backbone), "--out", str(estimated)]) == 0
    record = json.loads((estimated / "discrepancy.json").read_text())
    error = record["nominal_frequency_standard_error_hz"]
    assert abs(record["nominal_frequency_hz"] - loaded) < 3 * error
    assert abs(record["nominal_frequency_hz"] - REFERENCE_FREQUENCY_HZ) > 10 * error
    assert "stiffness_change" not in record["added"]
    assert "cannot be told from it" in record["nominal_caveat"]
    assert record["nominal_caveat"] in (estimated / "discrepancy.md").read_text()
    assert "nominal estimated from the file: it holds any offset at every amplitude" in capsys.readouterr().out
    half = tmp_path / "half"
    assert surrogacy(["discrepancy", str(backbone), "--nominal-frequency-hz", str(REFERENCE_FREQUENCY_HZ),
                      "--out", str(half)]) == 0
    caveat = json.loads((half / "discrepancy.json").read_text())["nominal_caveat"]
    assert "linear_damping" in caveat and "stiffness_change" not in caveat and "--nominal-damping" in caveat


@pytest.mark.parametrize("name, edit, expected", [
    ("simulated.csv", lambda text: text.replace("# provenance: virtual", "# provenance: simulated"),
     "field 'provenance': 'simulated'; expected one of measured, virtual, unknown"),
    ("empty.csv", lambda text: "", "field 'file': empty (0 bytes); expected a backbone: backbone CSV (.csv)"),
    ("empty.mat", lambda text: "", "field 'file': empty (0 bytes); expected a backbone: backbone CSV (.csv)"),
])
def test_a_file_that_is_no_backbone_is_refused_naming_it_and_what_was_expected(tmp_path, capsys, name, edit,
                                                                                expected):
    """A backbone stating a provenance outside the three, and an empty file (not called a ring-down and sent to
    freevib): one line naming the file, the field and what was expected; no output folder."""
    written = tmp_path / "written.csv"
    write_undeclared_backbone(written)
    assert "# provenance: virtual\n" in written.read_text()
    backbone = tmp_path / name
    backbone.write_text(edit(written.read_text()))
    out = tmp_path / "out"
    assert surrogacy(["discrepancy", str(backbone), "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and f"{backbone}: {expected}" in error and "freevib" not in error
    assert not out.exists()
