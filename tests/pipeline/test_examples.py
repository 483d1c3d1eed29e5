"""The examples a user copies from (examples/), each run as a user runs it, on the shared measured data
(skipped with the path in the reason where it is absent)."""

import subprocess
import sys

import pytest
from locations import REPOSITORY

ROOT = REPOSITORY
DATA = ROOT.parent / "shared" / "data"

pytestmark = pytest.mark.skipif(not (DATA / "asb-backbones").is_dir(), reason=f"shared data not found at {DATA}")


def run(script: str, *arguments) -> str:
    result = subprocess.run([sys.executable, str(ROOT / "examples" / script), *map(str, arguments)], cwd=ROOT,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_own_superelement_study(tmp_path):
    output = run("own_superelement_study.py", DATA, "--designs", 1000, "--out", tmp_path / "study")
    assert "C2: measured 249.63 Hz -> mode 2" in output and "surrogacy" in output


def test_dask_cluster_study_equals_the_serial_one(tmp_path):
    serial = run("own_superelement_study.py", DATA, "--designs", 1000, "--out", tmp_path / "serial")
    cluster = run("dask_cluster_study.py", DATA, "--designs", 1000, "--out", tmp_path / "cluster")
    assert serial.split("surrogacy")[1] == cluster.split("surrogacy")[1]


def test_discrepancy_on_ringdown():
    output = run("discrepancy_on_ringdown.py", DATA / "chen2022-brb-hammer" / "HammerImpact.mat", "--mode-hz", 80.5)
    assert "effects found: ['microslip'" in output
