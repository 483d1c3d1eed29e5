"""The plumbing every stage shares: the sidecar cache check and the configuration reader (no meshing, < 1 s)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from geometry.parameters import BEAMS, MeshParameters
from pipeline.cache import StageInputError, is_current, sidecar_record, upstream_file
from pipeline.config import ConfigError, resolve
from pipeline.files import json_float, write_json

INPUTS = {"beam": "BRB", "size": 0.005}
VERSIONS = {"format": 1, "numpy": "2.0"}


@pytest.fixture
def result(tmp_path):
    """A stage result: two output files and their sidecar, written as a stage writes them."""
    files = {"npz": tmp_path / "BRB.npz", "png": tmp_path / "BRB.png"}
    for path in files.values():
        path.write_bytes(path.name.encode())
    sidecar = tmp_path / "BRB.json"
    write_json(sidecar, sidecar_record(INPUTS, VERSIONS, files, first_bending_hz=169.5))
    return sidecar, files


def test_json_files_are_strict_with_every_number_that_is_not_finite_as_null(tmp_path):
    """write_json writes NaN and infinities (Python's and numpy's, in dicts, lists, tuples and arrays) as null and
    numpy scalars as numbers: Python's json reads the file back with a parse_constant that refuses NaN and
    Infinity, and json_float reads the null back as NaN."""
    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")

    path = tmp_path / "record.json"
    write_json(path, {"nan": float("nan"), "infinity": np.float32("inf"), "finite": np.float32(0.5),
                      "count": np.int64(3), "flag": np.bool_(True), "text": "NaN",
                      "nested": [np.nan, {"below": -np.inf}, (1.5, np.inf)], "array": np.array([[1.0, np.nan]])})
    record = json.loads(path.read_text(), parse_constant=refuse)
    assert record == {"nan": None, "infinity": None, "finite": 0.5, "count": 3, "flag": True, "text": "NaN",
                      "nested": [None, {"below": None}, [1.5, None]], "array": [[1.0, None]]}
    assert np.isnan(json_float(record["nan"])) and json_float(record["finite"]) == 0.5


def test_a_sidecar_matching_inputs_versions_and_files_is_current(result):
    sidecar, files = result
    assert is_current(sidecar, INPUTS, VERSIONS, files)
    assert is_current(sidecar, INPUTS, VERSIONS, ["npz"])  # a result with more files than asked for serves
    assert json.loads(sidecar.read_text())["first_bending_hz"] == 169.5


@pytest.mark.parametrize("change", ["inputs", "versions", "kinds", "file", "missing file"])
def test_any_change_makes_the_result_stale(result, change):
    sidecar, files = result
    inputs, versions, kinds = INPUTS, VERSIONS, list(files)
    if change == "inputs":
        inputs = {**INPUTS, "size": 0.004}
    elif change == "versions":
        versions = {**VERSIONS, "numpy": "2.1"}
    elif change == "kinds":
        kinds.append("mat")
    elif change == "file":
        files["png"].write_bytes(b"changed")
    else:
        files["npz"].unlink()
    assert not is_current(sidecar, inputs, versions, kinds)


@pytest.mark.parametrize("content", [b"", b'{"input_hash": "ab', b"[]", b"null", b'{"files": 3}', b"\xff\xfe"])
def test_a_corrupt_sidecar_is_stale_not_an_error(result, content):
    sidecar, files = result
    sidecar.write_bytes(content)
    assert not is_current(sidecar, INPUTS, VERSIONS, files)


def test_a_truncated_sidecar_is_stale_not_an_error(result):
    sidecar, files = result
    sidecar.write_bytes(sidecar.read_bytes()[:-40])
    assert not is_current(sidecar, INPUTS, VERSIONS, files)


def test_an_upstream_result_is_checked_and_its_problems_named(result):
    sidecar, files = result
    assert upstream_file(sidecar, "npz", "fe")[0] == files["npz"]
    with pytest.raises(StageInputError, match="files.mat.name"):
        upstream_file(sidecar, "mat", "fe")
    files["npz"].write_bytes(b"changed")
    with pytest.raises(StageInputError, match="SHA-256 differs.*run the FE stage first"):
        upstream_file(sidecar, "npz", "fe")
    sidecar.write_text('{"files": ')
    with pytest.raises(StageInputError, match="files.npz.name"):
        upstream_file(sidecar, "npz", "fe")
    with pytest.raises(StageInputError, match="missing; run the geometry stage first"):
        upstream_file(sidecar.with_name("LBRB.json"), "msh", "beams")


def test_configuration_file_then_overrides_with_numbers_typed():
    defaults = {"mesh": MeshParameters(), **BEAMS}
    resolved = resolve(defaults, {"mesh": {"size": 0.01}, "SBRB": {"bolt_x": [-0.03, 0, 0.03]}},
                       [("mesh", "size", 1), ("mesh", "order", 2)])
    assert resolved["mesh"] == MeshParameters(size=1.0, order=2)
    assert isinstance(resolved["mesh"].size, float)
    assert resolved["SBRB"].bolt_x == (-0.03, 0.0, 0.03) and resolved["BRB"] == BEAMS["BRB"]


@pytest.mark.parametrize("config, overrides, words", [
    ({}, [("mesh", "size", "fine")], ["[mesh]", "'size'", "expected float"]),
    ({}, [("mesh", "order", 1.5)], ["[mesh]", "'order'", "expected int"]),
    ({}, [("BRB", "bolt_x", 0.0)], ["[BRB]", "'bolt_x'", "expected tuple[float, ...]"]),
    ({}, [("BRB", "patch_cuts", [0.0, "a", 1.0])], ["'patch_cuts'", "expected float"]),
    ({}, [("BRB", "name", "X")], ["unknown field", "'name'"]),
    ({"meshes": {"size": 0.01}}, [], ["unknown section", "meshes"]),
    ({"mesh": 0.01}, [], ["['mesh'] must be tables"]),
    ({}, [("mesh", "size", -1)], ["[mesh]", "'size'", "expected a positive"]),
])
def test_bad_configuration_names_source_section_and_field(config, overrides, words):
    with pytest.raises(ConfigError) as error:
        resolve({"mesh": MeshParameters(), **BEAMS}, config, overrides, "beams.toml")
    assert all(word in str(error.value) for word in ["beams.toml", *words]), str(error.value)
