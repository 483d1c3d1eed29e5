"""``surrogacy fe`` on the coarse BRB: files, cache hit and content against a direct computation (about 20 s)."""

import json

import numpy as np
import pytest

from conftest import COARSE
from fem.fe_files import FeInputError, make_fe, read_csr
from fem.prestress import prestressed_beam
from geometry.beam_mesh import read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BEAMS
from cli.console import parser


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    beams = tmp_path_factory.mktemp("beams")
    make_beam(BEAMS["BRB"], COARSE, beams, render=False)
    return beams, tmp_path_factory.mktemp("fe")


def test_fe_command_writes_the_model_and_a_rerun_does_nothing(folders):
    beams, out = folders
    arguments = parser().parse_args(["fe", "--beam", "BRB", "--beams", str(beams), "--out", str(out), "--modes", "8"])
    arguments.run(arguments)
    result, sidecar = out / "BRB.npz", out / "BRB.json"
    stamp = (result.stat().st_mtime_ns, sidecar.stat().st_mtime_ns)
    arguments.run(arguments)
    assert (result.stat().st_mtime_ns, sidecar.stat().st_mtime_ns) == stamp

    direct = prestressed_beam(read_beam_mesh(beams / "BRB.msh"), BEAMS["BRB"], n_modes=8)
    with np.load(result, allow_pickle=False) as arrays:
        # Same inputs, same deterministic assembly: matrices identical; eigenvalues to the solver's round-off.
        assert abs(read_csr(arrays, "stiffness") - direct.stiffness).max() == 0.0
        assert abs(read_csr(arrays, "mass") - direct.mass).max() == 0.0
        assert abs(read_csr(arrays, "stress_stiffness") - direct.stress_stiffness).max() == 0.0
        np.testing.assert_array_equal(arrays["coordinates"], direct.coordinates)
        np.testing.assert_array_equal(arrays["contact_force"], direct.contact.normal_force)
        np.testing.assert_allclose(arrays["frequencies"][6:], direct.frequencies[6:], rtol=1e-9)
        np.testing.assert_allclose(arrays["prestressed_frequencies"][6:], direct.prestressed_frequencies[6:],
                                   rtol=1e-9)
        assert arrays["shapes"].shape == (direct.stiffness.shape[0], 8)
    record = json.loads(sidecar.read_text())
    assert record["inputs"]["n_modes"] == 8
    assert record["first_bending_hz"]["tied_prestressed"] < record["first_bending_hz"]["tied"]


def test_missing_or_tampered_inputs_raise_clear_errors(folders, tmp_path):
    beams, _ = folders
    with pytest.raises(FeInputError, match="missing; run the geometry stage"):
        make_fe("BRB", tmp_path, tmp_path / "fe")
    (tmp_path / "BRB.json").write_text(json.dumps({"beam": {}}))
    with pytest.raises(FeInputError, match="files.msh.name"):
        make_fe("BRB", tmp_path, tmp_path / "fe")
    record = json.loads((beams / "BRB.json").read_text())
    record["files"]["msh"]["sha256"] = "0" * 64
    (tmp_path / "BRB.json").write_text(json.dumps(record))
    (tmp_path / "BRB.msh").write_bytes((beams / "BRB.msh").read_bytes())
    with pytest.raises(FeInputError, match="SHA-256 differs"):
        make_fe("BRB", tmp_path, tmp_path / "fe")
    with pytest.raises(FeInputError, match="at least 7"):
        make_fe("BRB", beams, tmp_path / "fe", n_modes=6)
