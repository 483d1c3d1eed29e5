"""The examples a user copies from (examples/), each run as a user runs it: on the project's own data (the beams'
superelements with virtual measurements, a virtual ring-down), and on the shared measured data where it is present
(skipped with the path in the reason otherwise)."""

import subprocess
import sys

import pytest

from locations import REPOSITORY, SHARED

DATA = SHARED / "data"
shared_data = pytest.mark.skipif(not (DATA / "asb-backbones").is_dir(), reason=f"shared data not found at {DATA}")


def run(script: str, *arguments) -> str:
    result = subprocess.run([sys.executable, str(REPOSITORY / "examples" / script), *map(str, arguments)],
                            cwd=REPOSITORY, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_own_superelement_study_on_the_beams_accepts_the_known_joint_s_neighbours(beam_roms, tmp_path):
    output = run("own_superelement_study.py", "--rom", beam_roms, "--designs", 1000, "--out", tmp_path / "study")
    assert "BRB: measured" in output and "-> mode 1" in output and "surrogacy" in output


def test_dask_cluster_study_equals_the_serial_one(beam_roms, tmp_path):
    serial = run("own_superelement_study.py", "--rom", beam_roms, "--designs", 1000, "--out", tmp_path / "serial")
    cluster = run("dask_cluster_study.py", "--rom", beam_roms, "--designs", 1000, "--out", tmp_path / "cluster")
    assert serial.split("accepted")[1] == cluster.split("accepted")[1]


def test_discrepancy_on_a_virtual_ringdown_finds_the_microslip_put_in():
    output = run("discrepancy_on_ringdown.py")
    assert "virtual ring-down (microslip put in)" in output and "effects found: ['microslip']" in output


@shared_data
def test_own_superelement_study_on_the_asb(tmp_path):
    output = run("own_superelement_study.py", "--data", DATA, "--designs", 1000, "--out", tmp_path / "study")
    assert "C2: measured 249.63 Hz -> mode 2" in output and "surrogacy" in output


@shared_data
def test_discrepancy_on_the_measured_ringdown():
    """The beam's joint slips in microslip: microslip is among the effects found, the nominal estimated."""
    output = run("discrepancy_on_ringdown.py", DATA / "chen2022-brb-hammer" / "HammerImpact.mat", "--mode-hz", 80.5)
    found = next(line for line in output.splitlines() if line.startswith("effects found:"))
    assert "'microslip'" in found and "estimated from the measurement" in output
