"""Bad input at the door of the stages: options named as the user typed them, output
folders that cannot be one, upstream files damaged behind their recorded hash, a truncated own sidecar, and ring-
down time columns rounded in the file. Each refusal is one line naming the file or option and what was expected,
exit 2, with nothing written (temporaries included); never a traceback, a hang or a silently wrong result."""

import hashlib
import json
import shutil

import numpy as np
import pytest

from cli.console import main as surrogacy
from pipeline.files import PARTIAL

COARSE = ["--set", "mesh.size=0.0127", "--set", "mesh.lap_size=0.0064", "--set", "mesh.hole_size=0.0032"]
SAMPLE_RATE = 12800.0  # Hz, as the measured HammerImpact.mat
MODE_HZ, DAMPING = 80.0, 0.002


def refused(capsys, message: str, *names: str) -> str:
    """stderr of a run that gave status 2, checked to be one line holding ``message`` and every path in ``names``."""
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip() and "%|" not in line]
    error = "\n".join(lines)  # the progress bars of a stage that got as far as its loop aside
    assert "Traceback" not in error and len(lines) == 1, error
    assert message in error and all(name in error for name in names), error
    return error


def write_ring_down(path, time: np.ndarray) -> None:
    """A single-mode free decay (MODE_HZ, DAMPING) of one accelerometer at the sample times ``time``, written as
    a CSV with ``time`` as given (so a rounded column stays rounded)."""
    omega = 2 * np.pi * MODE_HZ
    exact = np.arange(time.size) / SAMPLE_RATE
    signal = np.exp(-DAMPING * omega * exact) * np.sin(omega * np.sqrt(1 - DAMPING ** 2) * exact)
    noise = 1e-5 * np.random.default_rng(0).standard_normal(time.size)
    lines = [f"{t!r},{a!r}" for t, a in zip(time.tolist(), (signal + noise).tolist())]
    path.write_text("time [s],acc1 [m/s^2]\n" + "\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def ring_down(tmp_path_factory):
    """A clean synthetic ring-down, 3 s at SAMPLE_RATE."""
    path = tmp_path_factory.mktemp("ring_down") / "decay.csv"
    write_ring_down(path, np.arange(int(3 * SAMPLE_RATE)) / SAMPLE_RATE)
    return path


OPTION_CASES = [  # (arguments before --out, message); RING_DOWN stands for the ring_down fixture's file
    (["beams", "--beam", "BRB", "--no-render", *COARSE, "--set", "BRB.patch_cuts=0.5"],
     "field 'patch_cuts' = 0.5: expected tuple[float, ...]"),
    (["beams", "--beam", "BRB", "--no-render", *COARSE, "--set", "BRB.patch_cuts=[0.5]"],
     "parameter 'patch_cuts' = (0.5,): expected fractions of the lap length"),
    (["beams", "--beam", "BRB", "--no-render", *COARSE, "--set", "mesh.patch_cuts=0.5"],
     "unknown field(s) ['patch_cuts'] in [mesh]"),
    (["fe", "--beam", "BRB", "--beams", "no_beams", "--modes", "3"], "option --modes = 3: expected at least 7"),
    (["rom", "--beam", "BRB", "--beams", "no_beams", "--fe", "no_fe", "--modes", "0"],
     "option --modes = 0: expected at least 1"),
    (["tune-frequencies", "--mesh-factor", "0"], "option --mesh-factor = 0.0: expected a positive scale factor"),
    (["tune-frequencies", "--mesh-factor", "0.01"], "option --mesh-factor = 0.01: parameter 'size' = 6.35e-05: expected "
                                             "an element size giving at most 5,000,000 tetrahedra"),
    (["tune-frequencies", "--stiffness", "-1"], "option --stiffness = -1.0: expected a patch stiffness from 1e+06"),
    (["freevib", "RING_DOWN", "--mode-hz", "-5"], "option --mode-hz = -5.0: expected a positive natural frequency"),
    (["freevib", "RING_DOWN", "--mode-hz", "nan"], "option --mode-hz = nan"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--band", "100", "60"], "option --band = [100.0, 60.0]: expected "
                                                                         "finite edges LOW < HIGH"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--band", "-10", "100"], "option --band = [-10.0, 100.0]"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--trim-periods", "-5"], "option --trim-periods = -5.0: expected "
                                                                          "a finite number of periods >= 0"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--smoothing-periods", "0"], "option --smoothing-periods = 0.0"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--grid-points", "0"], "option --grid-points = 0: expected an "
                                                                        "integer >= 2"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--cycles", "0"], "option --cycles = 0: expected an integer >= 1"),
    (["freevib", "RING_DOWN", "--mode-hz", "80", "--mode-index", "0"], "option --mode-index = 0"),
    (["freevib", "RING_DOWN", "--mode-hz", "6000"], "the band 4200-7800 Hz set by --mode-hz / --band must lie below "
                                                    "its Nyquist frequency 6400 Hz"),
]


@pytest.mark.parametrize("arguments, message", OPTION_CASES,
                         ids=[" ".join(case[0][:1] + case[0][-2:]) for case in OPTION_CASES])
def test_bad_option_is_named_as_typed_and_writes_nothing(tmp_path, capsys, ring_down, arguments, message):
    """Every option out of range is refused before any input is read, named as the user typed it (not by the
    library's internal name), with what was expected, and no output folder is left behind."""
    out = tmp_path / "out"
    arguments = [str(ring_down) if argument == "RING_DOWN" else argument for argument in arguments]
    assert surrogacy([*arguments, "--out", str(out)]) == 2
    refused(capsys, message)
    assert not out.exists()


@pytest.mark.parametrize("arguments", [["beams", "--beam", "BRB", "--no-render", *COARSE],
                                       ["fe", "--beam", "BRB", "--beams", "no_beams"],
                                       ["rom", "--beam", "BRB", "--beams", "no_beams", "--fe", "no_fe"],
                                       ["freevib", "RING_DOWN", "--mode-hz", "80"],
                                       ["tune-frequencies"], ["fe-convergence"]], ids=lambda arguments: arguments[0])
@pytest.mark.parametrize("below", [False, True], ids=["file", "below a file"])
def test_out_that_is_a_file_is_refused_at_the_door(tmp_path, capsys, ring_down, arguments, below):
    """--out naming a file (or a path below one) is refused before any input is read, also by calibrate and
    fe-convergence, which would otherwise find it only after every mesh was solved (minutes)."""
    blocker = tmp_path / "results"
    blocker.write_text("not a folder\n")
    out = blocker / "sub" if below else blocker
    arguments = [str(ring_down) if argument == "RING_DOWN" else argument for argument in arguments]
    assert surrogacy([*arguments, "--out", str(out)]) == 2
    refused(capsys, "expected an output folder", str(out))
    assert blocker.read_text() == "not a folder\n" and sorted(tmp_path.iterdir()) == [blocker]


@pytest.fixture(scope="module")
def coarse_brb(tmp_path_factory):
    """The geometry stage's coarse BRB (mesh and sidecar, no render)."""
    folder = tmp_path_factory.mktemp("coarse_brb")
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(folder), *COARSE]) == 0
    return folder


def rehash(sidecar, kind: str) -> None:
    """Record the current SHA-256 of the ``kind`` file in ``sidecar``: a damaged file the sidecar vouches for."""
    record = json.loads(sidecar.read_text())
    entry = record["files"][kind]
    entry["sha256"] = hashlib.sha256((sidecar.parent / entry["name"]).read_bytes()).hexdigest()
    sidecar.write_text(json.dumps(record))


def no_results(folder) -> bool:
    """Whether ``folder`` holds no result and no temporary (its lock file aside), or does not exist."""
    return not folder.exists() or not [path for path in folder.rglob("*") if path.name != ".lock"]


def test_fe_names_a_renamed_physical_group(coarse_brb, tmp_path, capsys):
    """A washer group renamed in the .msh (its hash recorded anew) was a KeyError traceback in fem.bolts."""
    beams = tmp_path / "beams"
    shutil.copytree(coarse_brb, beams)
    mesh = beams / "BRB.msh"
    mesh.write_text(mesh.read_text().replace('"lower_washer_1"', '"lower_washer_one"'))
    rehash(beams / "BRB.json", "msh")
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(beams), "--out", str(out)]) == 2
    refused(capsys, "physical group 'lower_washer_1' missing or empty", str(mesh))
    assert no_results(out)


def test_fe_names_an_empty_mesh_its_sidecar_vouches_for(coarse_brb, tmp_path, capsys):
    """An empty .msh whose hash the sidecar records (a disk that filled up as it was written, then rehashed) was
    numpy's "zero-size array to reduction operation maximum", without the file."""
    beams = tmp_path / "beams"
    shutil.copytree(coarse_brb, beams)
    (beams / "BRB.msh").write_bytes(b"")
    rehash(beams / "BRB.json", "msh")
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(beams), "--out", str(out)]) == 2
    refused(capsys, "no nodes (an empty or truncated mesh file", str(beams / "BRB.msh"))
    assert no_results(out)


@pytest.mark.parametrize("key", ["files", "inputs"])
def test_fe_names_a_sidecar_without_a_key_before_touching_its_output(coarse_brb, tmp_path, capsys, key):
    beams = tmp_path / "beams"
    shutil.copytree(coarse_brb, beams)
    record = json.loads((beams / "BRB.json").read_text())
    del record[key]
    (beams / "BRB.json").write_text(json.dumps(record))
    out = tmp_path / "fe"
    assert surrogacy(["fe", "--beam", "BRB", "--beams", str(beams), "--out", str(out)]) == 2
    refused(capsys, f"KeyError('{key}')", str(beams / "BRB.json"))
    assert not out.exists()


def fe_result(folder, coarse_brb, arrays: dict | None, raw: bytes | None = None) -> None:
    """An FE stage folder for the coarse BRB whose sidecar vouches for a .npz of ``arrays`` (or ``raw`` bytes)."""
    folder.mkdir()
    npz = folder / "BRB.npz"
    if raw is None:
        with open(npz, "wb") as stream:
            np.savez(stream, **arrays)
    else:
        npz.write_bytes(raw)
    mesh_sha = json.loads((coarse_brb / "BRB.json").read_text())["files"]["msh"]["sha256"]
    (folder / "BRB.json").write_text(json.dumps({"inputs": {"mesh_sha256": mesh_sha}, "input_hash": "0",
                                                 "files": {"npz": {"name": "BRB.npz", "sha256": "0"}}}))
    rehash(folder / "BRB.json", "npz")


@pytest.mark.parametrize("content, message", [
    ("truncated", "not a readable .npz of the FE stage (File is not a zip file)"),
    ("not a zip", "not a readable .npz of the FE stage"),
    ("without mass", "array(s) ['mass_data'] missing from the FE stage's .npz"),
])
def test_rom_names_a_damaged_fe_file_before_touching_its_output(coarse_brb, tmp_path, capsys, content, message):
    """A truncated FE .npz whose hash the sidecar records was a BadZipFile traceback, a file of other bytes a
    message about pickles naming no file, an .npz without an array a KeyError traceback."""
    arrays = {"coordinates": np.zeros((4, 3)), **{f"{matrix}_{part}": np.zeros(3) for part in ("data", "indices",
              "indptr", "shape") for matrix in ("stiffness", "mass", "stress_stiffness")}}
    fe = tmp_path / "fe"
    if content == "truncated":
        fe_result(tmp_path / "whole", coarse_brb, arrays)
        fe_result(fe, coarse_brb, None, (tmp_path / "whole" / "BRB.npz").read_bytes()[:200])
    elif content == "not a zip":
        fe_result(fe, coarse_brb, None, b"not a zip file\n")
    else:
        fe_result(fe, coarse_brb, {key: value for key, value in arrays.items() if key != "mass_data"})
    out = tmp_path / "rom"
    assert surrogacy(["rom", "--beam", "BRB", "--beams", str(coarse_brb), "--fe", str(fe), "--out", str(out)]) == 2
    refused(capsys, message, str(fe / "BRB.npz"))
    assert not out.exists()


def test_truncated_own_sidecar_is_stale_said_in_one_line(coarse_brb, tmp_path, capsys):
    """A truncated sidecar of the stage's own result is recomputed (the same bytes as before), and said so."""
    beams = tmp_path / "beams"
    shutil.copytree(coarse_brb, beams)
    sidecar = beams / "BRB.json"
    whole = sidecar.read_bytes()
    sidecar.write_bytes(whole[:300])
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(beams), *COARSE]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if str(sidecar) in line and "stale" in line]
    assert lines == [f"{sidecar}: unreadable sidecar (truncated or not a JSON object): stale, recomputing"]
    assert sidecar.read_bytes() == whole and not list(beams.glob(f"{PARTIAL}*"))


def test_time_rounded_to_a_microsecond_reads_as_its_uniform_grid(ring_down, tmp_path):
    """A time column rounded to 1 us (0.0064 of the 78 us step) was refused as 'not uniformly sampled'; it is the
    uniform sampling it rounds. The decay's undamped frequency is MODE_HZ, recovered to the 1e-5 noise level (3.7e-6
    measured). The rounded file's grid step differs from the exact one by the rounding of its last time (at most
    1.7e-7 relative), so the frequencies agree to 1e-6 (2.3e-7 measured). The estimates near a bin's edges change
    bins with it: each point's amplitude agrees to 1e-3 in log amplitude, a hundredth of the grid's spacing (0.11;
    8e-5 measured), and each damping value by less than its own stated uncertainty (0.34 of it at most)."""
    rounded = tmp_path / "decay.csv"
    write_ring_down(rounded, np.round(np.arange(int(3 * SAMPLE_RATE)) / SAMPLE_RATE, 6))
    tables = []
    for path, out in ((ring_down, tmp_path / "exact"), (rounded, tmp_path / "rounded")):
        assert surrogacy(["freevib", str(path), "--mode-hz", str(MODE_HZ), "--out", str(out)]) == 0
        tables.append(np.genfromtxt(out / "decay_mode_80Hz.csv", delimiter=",", names=True))
    exact, from_rounded = tables
    assert np.allclose(exact["natural_frequency_hilbert_Hz"], MODE_HZ, rtol=1e-5)
    for column in ("natural_frequency_hilbert_Hz", "natural_frequency_cycles_Hz"):
        assert np.allclose(from_rounded[column], exact[column], rtol=1e-6)
    assert np.max(np.abs(np.log(from_rounded["amplitude_m"] / exact["amplitude_m"]))) < 1e-3
    for estimator in ("hilbert", "cycles"):
        change = np.abs(from_rounded[f"damping_ratio_{estimator}_"] - exact[f"damping_ratio_{estimator}_"])
        assert np.all(change < exact[f"damping_ratio_{estimator}_uncertainty_"])


def test_time_column_with_a_missing_sample_is_refused_naming_the_tolerance(tmp_path, capsys):
    path = tmp_path / "gap.csv"
    write_ring_down(path, np.delete(np.arange(int(3 * SAMPLE_RATE)) / SAMPLE_RATE, 20000))
    out = tmp_path / "out"
    assert surrogacy(["freevib", str(path), "--mode-hz", str(MODE_HZ), "--out", str(out)]) == 2
    refused(capsys, "field 'time': not uniformly sampled: sample times lie up to 0.52 of a time step off the uniform "
                    "grid; at most 0.01 is accepted", str(path))
    assert not out.exists()
