"""Bad values at the door of the stages (configuration fields, material, mesh-convergence options, FE sidecars,
ring-down files): one line naming the source, the field and what was expected, exit 2, and nothing written;
never a traceback, a hang or a silently wrong result."""

import numpy as np
import pytest

from cli.console import main as surrogacy

CASES = [
    (["beams", "--beam", "BRB", "--no-render", "--set", "mesh.size=abc"], "field 'size' = 'abc': expected float"),
    (["beams", "--beam", "BRB", "--no-render", "--set", "mesh.size=true"], "field 'size' = True: expected float"),
    (["beams", "--beam", "BRB", "--no-render", "--set", "mesh.size=inf"], "parameter 'size' = inf"),
    (["beams", "--beam", "BRB", "--no-render", "--set", "BRB.body_length=inf"], "parameter 'body_length' = inf"),
    (["beams", "--beam", "BRB", "--no-render", "--set", "BRB.density=inf"], "parameter 'density' = inf"),
    (["beams", "--beam", "BRB", "--no-render", "--set", "mesh.size=1e-4"], "at most 5,000,000 tetrahedra"),
    (["study", "--set", "study.dataset=bridge"], "field 'dataset' = 'bridge'"),
    (["study", "--set", "study.n_levels=2"], "field 'n_levels' = 2"),
    (["study", "--set", "study.prestress=1"], "field 'prestress' = 1"),
    (["study", "--set", "sample.n_designs=0"], "n_designs must be at least 1"),
    (["study", "--set", "acceptance.damping_tolerance=0"], "field 'damping_tolerance' = 0"),
]


@pytest.mark.parametrize("arguments, message", CASES, ids=[" ".join(case[0][:1] + case[0][-1:]) for case in CASES])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, arguments, message):
    out = tmp_path / "out"
    assert surrogacy([*arguments, "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert message in error and "Traceback" not in error and len(error.strip().splitlines()) == 1
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("option, value, field", [("--youngs-modulus", "190", "youngs_modulus"),
                                                  ("--poissons-ratio", "0.5", "poissons_ratio"),
                                                  ("--density", "-1", "density")])
def test_material_outside_structural_solids_is_refused(tmp_path, capsys, option, value, field):
    """E typed in GPa made ARPACK spin for minutes on modes all near 0 Hz; nu = 0.5 and a negative density broke
    the factorisation: refused at the door, naming the field, before the geometry stage's files are read."""
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(tmp_path / "no_beams"), "--out", str(out),
                      option, value]) == 2
    assert f"field '{field}'" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("setting, message", [
    ("bolt.preload=nan", "field 'preload' = nan: expected a finite value > 0 N"),
    ("bolt.preload=-1", "field 'preload' = -1.0: expected a finite value > 0 N"),
    ("bolt.area=-1", "field 'area' = -1.0: expected a finite value > 0 m^2"),
    ("bolt.poissons_ratio=0.5", "field 'poissons_ratio' = 0.5: expected 0 <= nu < 0.5"),
    ("bolt.mass=inf", "field 'mass' = inf: expected a finite value >= 0 kg")])
def test_bolt_outside_its_physical_range_is_refused(tmp_path, capsys, setting, message):
    """A NaN or negative preload or a negative shank area reached the contact solve and ended in a CHOLMOD
    traceback (not positive definite): refused at the door, exit 2, one line naming the source, the [bolt] table,
    the field and what was expected, before the geometry stage's files are read; nothing written."""
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(tmp_path / "no_beams"), "--out", str(out),
                      "--set", setting]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [f"surrogacy fe: error: command line: [bolt] {message}"]
    assert not out.exists()


@pytest.mark.parametrize("arguments, message", [(["--tolerance", "-1"], "option --tolerance = -1.0"),
                                                (["--factors", "0"], "option --factors = [0.0]"),
                                                (["--factors", "1", "0.01"], "option --factors = 0.01: parameter "
                                                 "'size' = 6.35e-05: expected an element size giving at most")])
def test_convergence_options_are_checked_before_meshing(tmp_path, capsys, arguments, message):
    out = tmp_path / "convergence"
    assert surrogacy(["fe-convergence", "--out", str(out), *arguments]) == 2
    assert message in capsys.readouterr().err and not out.exists()


@pytest.fixture(scope="module")
def coarse_beams(tmp_path_factory):
    """Coarse BRB and LBRB meshes from the geometry stage."""
    folder = tmp_path_factory.mktemp("coarse_beams")
    assert surrogacy(["beams", "--beam", "BRB", "LBRB", "--no-render", "--out", str(folder),
                      "--set", "mesh.size=0.0127", "--set", "mesh.lap_size=0.0064", "--set", "mesh.hole_size=0.0032"]) == 0
    return folder


def test_fe_refuses_a_sidecar_of_another_beam(coarse_beams, tmp_path, capsys):
    """The LBRB's files with the BRB's name made the FE stage build the LBRB as 'BRB' (exit 0, 91.5 Hz instead of
    198.3): the sidecar now has to describe the beam asked for."""
    import shutil

    swapped = tmp_path / "swap"
    swapped.mkdir()
    for path in coarse_beams.glob("LBRB.*"):
        shutil.copy(path, swapped / path.name)
    shutil.copy(swapped / "LBRB.json", swapped / "BRB.json")
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(swapped), "--out", str(out)]) == 2
    assert "describes beam 'LBRB'" in capsys.readouterr().err and not any(out.glob("*.npz"))


def test_fe_refuses_a_hand_edited_sidecar(coarse_beams, tmp_path, capsys):
    """Editing beam.height in the geometry sidecar moved the first bending silently: the sidecar's inputs must
    still hash to its recorded input_hash."""
    import json
    import shutil

    edited = tmp_path / "edited"
    shutil.copytree(coarse_beams, edited)
    record = json.loads((edited / "BRB.json").read_text())
    record["inputs"]["beam"]["height"] *= 1.1
    (edited / "BRB.json").write_text(json.dumps(record))
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(edited), "--out", str(out)]) == 2
    assert "edited after meshing" in capsys.readouterr().err and not any(out.glob("*.npz"))


def test_ring_down_csv_with_a_byte_order_mark_reads(tmp_path):
    """Excel's "CSV UTF-8" starts with a byte-order mark: read as the same file without it."""
    from experiment.measured_files import read_ringdown

    text = "time [s],acc1 [m/s^2]\n" + "\n".join(f"{k / 1000},{np.sin(k / 10)}" for k in range(100)) + "\n"
    (tmp_path / "plain.csv").write_text(text)
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + text.encode())
    plain, bom = read_ringdown(tmp_path / "plain.csv")[0], read_ringdown(tmp_path / "bom.csv")[0]
    assert bom.channels == plain.channels and np.array_equal(bom.signals, plain.signals)


@pytest.mark.parametrize("name, content, message", [
    ("twice.csv", "time [s],acc1 [m/s^2],acc1 [m/s^2]\n0,1,2\n0.001,1,2\n", "field 'acc1 [m/s^2]': column named more than once"),
    ("empty.mat", "", "field 'file': empty (0 bytes); expected a ring-down: ring-down CSV (.csv)"),
    ("empty.csv", "", "field 'file': empty (0 bytes); expected a ring-down: ring-down CSV (.csv)"),
    ("header.mat", "MATLAB 5.0", "not a readable MATLAB file"),
])
def test_unreadable_ring_downs_are_named(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    path.write_text(content)
    out = tmp_path / "out"
    assert surrogacy(["freevib", str(path), "--mode-hz", "80", "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert str(path) in error and message in error and not out.exists()


def test_an_error_a_library_words_over_several_lines_is_printed_as_one(tmp_path, capsys):
    """pandas words a garbled fronts file's parse error over two lines; the command prints it as one, with the
    file named, and exits 2."""
    from argparse import Namespace

    from calibration.workflow import check_fronts
    from cli.console import run

    fronts = tmp_path / "fronts_jenkins.csv"
    fronts.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(ValueError, match="\n"):  # the library's own wording spans lines
        check_fronts(fronts, "jenkins", 1, ["ASB C1"], 10)
    assert run(Namespace(command="fit", run=lambda arguments: check_fronts(fronts, "jenkins", 1, ["ASB C1"], 10))) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"surrogacy fit: error: {fronts}: not a readable fronts CSV (") and error.count("\n") == 1
