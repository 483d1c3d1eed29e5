"""Same inputs, same bytes: the geometry, FE and reduction stages run twice on the coarse BRB,
each time in a fresh interpreter with its own string-hash seed and time zone, give byte-identical build files
(every file's SHA-256, every array of every .npz), so that the stages' caches, keyed on their inputs' hashes,
hold."""

import os
import subprocess
import sys
import time

import numpy as np
import pytest
import scipy.io

from pipeline.files import MAT_DESCRIPTION, write_mat
from stage_runs import COARSE, digests

STAGES = ("beams", "fe", "rom")
OUTPUTS = {"beams": {"BRB.msh", "BRB.vtu", "BRB.png", "BRB.json"},
           "fe": {"BRB.npz", "BRB.json", "BRB_contact_pressure.png", "BRB_first_bending.png"},
           "rom": {"BRB.npz", "BRB.mat", "BRB.json", "BRB_first_bending.png"}}
CHAIN = """
import sys
from cli.console import main
out = sys.argv[1]
coarse = sys.argv[2:]
assert main(["beams", "--beam", "BRB", "--out", f"{out}/beams", *coarse]) == 0
assert main(["fe", "--beam", "BRB", "--beams", f"{out}/beams", "--out", f"{out}/fe"]) == 0
assert main(["rom", "--beam", "BRB", "--beams", f"{out}/beams", "--fe", f"{out}/fe", "--out", f"{out}/rom"]) == 0
"""


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """Two build folders, each made by beams, fe and rom on the coarse BRB in one fresh interpreter, with
    string-hash seeds 1 and 2 (an output depending on the order of a set of strings differs) and local times 14 h
    apart (a time of writing in local time differs although both run at once; about 35 s)."""
    folders = [tmp_path_factory.mktemp(f"run_{seed}") for seed in (1, 2)]
    processes = [subprocess.Popen([sys.executable, "-c", CHAIN, str(folder), *COARSE],
                                  env={**os.environ, "PYTHONHASHSEED": str(seed), "TZ": time_zone},
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                 for seed, time_zone, folder in zip((1, 2), ("UTC0", "LINT-14"), folders)]
    for process in processes:
        _, error = process.communicate(timeout=600)
        assert process.returncode == 0, error
    return folders


@pytest.mark.parametrize("stage", STAGES)
def test_same_inputs_give_byte_identical_files(two_runs, stage):
    first, second = (folder / stage for folder in two_runs)
    assert OUTPUTS[stage] <= {path.name for path in first.iterdir()}
    assert digests(first) == digests(second)


def test_mat_file_bytes_do_not_depend_on_the_clock(tmp_path, monkeypatch):
    """scipy.io.savemat wrote the time of writing into the .mat header, so the superelement's .mat and its sidecar
    changed on every run; write_mat's header is fixed and the file still reads as MATLAB 5."""
    content = {"K": np.arange(6.0).reshape(2, 3), "dof_labels": np.array(["u_x", "r_z"], dtype=object)}
    write_mat(tmp_path / "now.mat", content)
    monkeypatch.setattr(time, "asctime", lambda *arguments: "Fri Jan  1 00:00:00 2100")
    write_mat(tmp_path / "later.mat", content)
    assert (tmp_path / "now.mat").read_bytes() == (tmp_path / "later.mat").read_bytes()
    loaded = scipy.io.loadmat(tmp_path / "later.mat")
    assert loaded["__header__"] == MAT_DESCRIPTION and loaded["__version__"] == "1.0"
    assert np.array_equal(loaded["K"], content["K"])
    assert [str(label[0]) for label in loaded["dof_labels"].ravel()] == ["u_x", "r_z"]
