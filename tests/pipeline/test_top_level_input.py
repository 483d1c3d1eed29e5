"""Bad input at the top level: a missing data file named to make, an unknown beam name, a malformed
configuration. Each stops with one clear message naming what is wrong, and the results of earlier runs in the
output folder are left byte for byte as they were."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

import pytest

from locations import ASB_MODELS, REPOSITORY
from cli.console import main as surrogacy



def folder_digest(folder: Path) -> dict:
    """SHA-256 of every file under ``folder`` (the lock file, which a run may create, left out)."""
    return {path.relative_to(folder): hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(folder.rglob("*")) if path.is_file() and path.name != ".lock"}


@pytest.mark.parametrize("variable", ["RINGDOWN", "ASB_DATA", "REFERENCE"])
def test_make_stops_before_anything_runs_on_a_missing_data_file(tmp_path, variable):
    missing = tmp_path / "missing.mat"
    result = subprocess.run(["make", "-C", str(REPOSITORY), "demo", f"{variable}={missing}"], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2
    assert f"{variable}={missing}: no such file or folder" in result.stderr
    assert "surrogacy" not in result.stdout  # no stage started


@pytest.fixture(scope="module")
def coarse_beam_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("beams")
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(folder), "--set", "mesh.size=0.0127",
                      "--set", "mesh.lap_size=0.0064", "--set", "mesh.hole_size=0.0032"]) == 0
    return folder


@pytest.mark.parametrize("arguments, message", [
    (["beams", "--beam", "XBRB"], "invalid choice: 'XBRB'"),
    (["fe", "--beam", "SBRBX"], "invalid choice: 'SBRBX'"),
])
def test_unknown_beam_name_is_refused_by_name(coarse_beam_folder, capsys, arguments, message):
    before = folder_digest(coarse_beam_folder)
    with pytest.raises(SystemExit) as stop:
        surrogacy([*arguments, "--out", str(coarse_beam_folder)])
    assert stop.value.code == 2 and message in capsys.readouterr().err
    assert folder_digest(coarse_beam_folder) == before


@pytest.mark.parametrize("config, message", [
    ("[mesh\nsize = 0.01\n", "config.toml"),  # not TOML
    ("[mesh]\nsize = 'fine'\n", "field 'size' = 'fine': expected float"),
    ("[meshes]\nsize = 0.01\n", "meshes"),  # a table the stage does not have
])
def test_malformed_beams_config_leaves_earlier_results_intact(coarse_beam_folder, tmp_path, capsys, config,
                                                               message):
    path = tmp_path / "config.toml"
    path.write_text(config)
    before = folder_digest(coarse_beam_folder)
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(coarse_beam_folder),
                      "--config", str(path)]) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1
    assert folder_digest(coarse_beam_folder) == before


def test_malformed_study_config_leaves_earlier_results_intact(tmp_path, capsys):
    data = ASB_MODELS.parent
    if not (data / "asb-backbones").is_dir():
        pytest.skip(f"ASB data not available at {data} (shared data folder absent)")
    out = tmp_path / "study-asb"
    small = ["--set", "study.dataset=asb", "--set", "sample.n_designs=1000", "--set", "sample.chunk_size=1000",
             "--set", 'study.models=["jenkins"]', "--steps", "measurements", "explore"]
    assert surrogacy(["study", "--out", str(out), "--data", str(data), *small]) == 0
    before = folder_digest(out)
    config = tmp_path / "study.toml"
    config.write_text("[sample]\nn_designs = -5\n")
    assert surrogacy(["study", "--out", str(out), "--data", str(data), "--config", str(config), *small[:2]]) == 2
    assert "n_designs" in capsys.readouterr().err
    assert folder_digest(out) == before
