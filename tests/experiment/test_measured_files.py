"""The registry of measured-file formats: each format chosen by suffix and content from files the project's own
writers make, read into the right record, with the provenance the file states; a file of no format, or of the
other kind, refused in one line that names the file, its format and the formats expected."""

import numpy as np
import pytest
import scipy.io

from experiment.backbone import ModeBackbone, mode_backbone, ringdown_backbone
from experiment.backbone_files import read_backbone, write_backbone
from experiment.measured_files import (MEASURED_FORMATS, MeasuredFileError, measured_format, read_mode_backbone,
                                       read_ringdown, stated_provenance)
from experiment.ringdown import RingDown
from experiment.ringdown_files import write_ringdown_csv, write_ringdown_mat, write_ringdown_uff58
from test_backbone_files import FREQUENCY_HZ, linear_hits


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict:
    """One file of every format, format name -> path, written by the project's writers (the ASB layout by
    scipy.io, as the published files are)."""
    folder = tmp_path_factory.mktemp("measured")
    hits = linear_hits([1.0, 0.7])
    backbone = mode_backbone(ringdown_backbone(hits, FREQUENCY_HZ), "linear oscillator", "virtual",
                             {"mode_hz": FREQUENCY_HZ, "per_channel": False})
    paths = {"backbone CSV": folder / "backbone.csv", "ring-down CSV": folder / "ring.csv",
             "ASB backbone .mat (Q, W, Z)": folder / "ASB_X_20Nm_BB.mat", "ring-down .mat": folder / "ring.mat",
             "ring-down UFF 58": folder / "ring.uff"}
    write_backbone(backbone, paths["backbone CSV"])
    write_ringdown_csv(hits, paths["ring-down CSV"], comment="VIRTUAL data: a linear 50 Hz mode")
    points = backbone.backbone.with_data()
    scipy.io.savemat(paths["ASB backbone .mat (Q, W, Z)"], {
        "Q": points.amplitude[::-1, None], "W": points.natural_frequency_hz[::-1, None],
        "Z": points.damping_ratio[::-1, None]})
    write_ringdown_mat(hits, paths["ring-down .mat"])
    write_ringdown_uff58(hits, paths["ring-down UFF 58"])
    return paths


def test_every_format_is_recognised_and_read_into_its_record(files):
    assert sorted(files) == sorted(entry.name for entry in MEASURED_FORMATS)  # a new format needs its file here
    for name, path in files.items():
        entry = measured_format(path)
        assert entry.name == name
        content = entry.read(path)
        if entry.kind == "backbone":
            assert isinstance(content, ModeBackbone) and read_mode_backbone(path).structure == content.structure
        else:
            assert all(isinstance(hit, RingDown) for hit in content) and len(content) == 2
            np.testing.assert_allclose(read_ringdown(path)[1].signals, linear_hits([1.0, 0.7])[1].signals,
                                       rtol=1e-10, atol=1e-12)  # UFF's ASCII: 5e-13 of the unit amplitude


def test_the_estimation_settings_travel_in_the_backbone_csv(files):
    assert read_backbone(files["backbone CSV"]).settings == {"mode_hz": FREQUENCY_HZ, "per_channel": False}
    text = files["backbone CSV"].read_text().replace('# settings: {"mode_hz"', '# settings: {mode_hz')
    broken = files["backbone CSV"].with_name("broken.csv")
    broken.write_text(text)
    with pytest.raises(ValueError, match="broken.csv: field 'settings': not one JSON object"):
        read_backbone(broken)


@pytest.mark.parametrize("name, reader, expected", [
    ("ring-down CSV", read_mode_backbone, "format ring-down CSV; expected a backbone: backbone CSV (.csv); "
                                          "ASB backbone .mat (Q, W, Z) (.mat). Process a ring-down into a backbone "
                                          "CSV first: surrogacy freevib FILE --mode-hz F"),
    ("ring-down .mat", read_mode_backbone, "format ring-down .mat; expected a backbone"),
    ("backbone CSV", read_ringdown, "format backbone CSV; expected a ring-down: ring-down CSV (.csv); ring-down .mat "
                                    "(.mat); ring-down UFF 58 (.uff, .unv)"),
    ("ASB backbone .mat (Q, W, Z)", read_ringdown, "format ASB backbone .mat (Q, W, Z); expected a ring-down"),
])
def test_a_file_of_the_other_kind_is_refused_naming_its_format(files, name, reader, expected):
    with pytest.raises(MeasuredFileError) as error:
        reader(files[name])
    assert str(error.value).startswith(f"{files[name]}: field 'file': {expected}")


def test_a_file_of_no_known_format_is_refused_listing_the_formats(tmp_path):
    path = tmp_path / "hits.txt"
    path.write_text("0,1\n")
    with pytest.raises(MeasuredFileError, match=r"hits.txt: field 'file': unknown suffix '.txt'; known formats: "
                                                r"backbone CSV \(.csv\); ring-down CSV"):
        read_ringdown(path)
    with pytest.raises(MeasuredFileError, match="missing.mat: field 'file': does not exist"):
        read_mode_backbone(tmp_path / "missing.mat")


def test_each_format_states_its_provenance_or_says_unknown(files, tmp_path):
    """Where a file states what its data are, that is its provenance; where it does not, "unknown" (UFF 58 has no
    place for it); a statement outside the known ones is refused naming the file."""
    assert stated_provenance(files["ring-down CSV"]) == "virtual"  # its comment calls the data virtual
    assert stated_provenance(files["backbone CSV"]) == "virtual" and stated_provenance(files["ring-down UFF 58"]) == \
        "unknown"
    assert stated_provenance(files["ring-down .mat"]) == "unknown"
    hits = linear_hits([1.0])
    for provenance in ("measured", "virtual"):
        write_ringdown_mat(hits, tmp_path / f"{provenance}.mat", provenance=provenance)
        write_ringdown_csv(hits, tmp_path / f"{provenance}.csv", provenance=provenance)
        assert stated_provenance(tmp_path / f"{provenance}.mat") == stated_provenance(tmp_path / f"{provenance}.csv") \
            == provenance
    write_ringdown_csv(hits, tmp_path / "plain.csv")
    assert stated_provenance(tmp_path / "plain.csv") == "unknown"
    write_ringdown_csv(hits, tmp_path / "odd.csv", provenance="guessed")
    with pytest.raises(MeasuredFileError, match="odd.csv: field 'provenance': 'guessed'"):
        stated_provenance(tmp_path / "odd.csv")


def test_freevib_carries_the_file_s_provenance_and_refuses_a_contradiction(tmp_path, capsys):
    """The backbone freevib writes says what the ring-down says; --provenance declares it where the file does not
    say, and is refused (exit 2, one line) where the file says otherwise."""
    from cli.console import main as surrogacy

    hits = linear_hits([1.0, 0.7])
    write_ringdown_csv(hits, tmp_path / "virtual.csv", provenance="virtual")
    write_ringdown_csv(hits, tmp_path / "plain.csv")
    for name, declared, expected in (("virtual", None, "virtual"), ("plain", None, "unknown"),
                                     ("plain", "measured", "measured")):
        out = tmp_path / f"{name}-{declared}"
        assert surrogacy(["freevib", str(tmp_path / f"{name}.csv"), "--mode-hz", "50", "--out", str(out),
                          *(["--provenance", declared] if declared else [])]) == 0
        assert read_backbone(out / f"{name}_mode_50Hz_backbone.csv").provenance == expected
    capsys.readouterr()
    assert surrogacy(["freevib", str(tmp_path / "virtual.csv"), "--mode-hz", "50", "--provenance", "measured",
                      "--out", str(tmp_path / "refused")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"surrogacy freevib: error: option --provenance = measured: {tmp_path / 'virtual.csv'} states "
                     "its data virtual"]
    assert not (tmp_path / "refused").exists()
