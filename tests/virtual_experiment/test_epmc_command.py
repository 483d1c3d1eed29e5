"""``surrogacy epmc``: two backbone CSVs of one design on the BRB, EPMC beside QSMA, and bad input refused."""

import numpy as np

from experiment.backbone_files import read_backbone
from cli.console import main as surrogacy

JENKINS_DESIGN = "300,1e7,1e9,300,1e7,1e9,300,1e7,1e9"  # F_S, K_T, K_z of the BRB's three patch groups


def test_epmc_writes_both_backbones_at_the_same_amplitudes(beam_roms, tmp_path, capsys):
    """Stuck levels (below one slip amplitude, Jenkins) are the linear mode in both files to 1e-12 with zero
    damping (EPMC's to the round-off of its Newton solve, 1e-15); past slip both soften and damp, EPMC and QSMA within 0.5 % in frequency and 5 % in damping on this
    design (the harmonic count is given, so no convergence check runs)."""
    out = tmp_path / "epmc"
    status = surrogacy(["epmc", "--rom", str(beam_roms / "BRB.npz"), "--model", "jenkins", "--design",
                        JENKINS_DESIGN, "--from", "0.3", "--to", "8", "--levels", "4", "--harmonics", "3",
                        "--out", str(out)])
    assert status == 0
    epmc, qsma = (read_backbone(out / f"BRB_jenkins_{method}.csv") for method in ("epmc", "qsma"))
    assert epmc.provenance == qsma.provenance == "virtual"
    assert epmc.settings["harmonics"] == 3 and epmc.settings["samples"] == 256
    np.testing.assert_array_equal(epmc.backbone.amplitude, qsma.backbone.amplitude)
    slip = epmc.backbone.amplitude / epmc.settings["slip_amplitude"]
    stuck = slip < 1.0
    assert stuck.sum() == 2 and (~stuck).sum() == 2
    frequency = (epmc.backbone.natural_frequency_hz, qsma.backbone.natural_frequency_hz)
    damping = (epmc.backbone.damping_ratio, qsma.backbone.damping_ratio)
    np.testing.assert_allclose(frequency[0][stuck], frequency[1][stuck], rtol=1e-12)
    np.testing.assert_array_equal(damping[1][stuck], 0.0)
    np.testing.assert_allclose(damping[0][stuck], 0.0, rtol=0, atol=1e-15)
    assert np.all(frequency[0][~stuck] < frequency[0][0]) and np.all(damping[0][~stuck] > 1e-4)
    np.testing.assert_allclose(frequency[0], frequency[1], rtol=5e-3)
    np.testing.assert_allclose(damping[0][~stuck], damping[1][~stuck], rtol=5e-2)
    assert "harmonics: 3" in capsys.readouterr().out


def test_epmc_refuses_a_design_of_the_wrong_length_before_writing(beam_roms, tmp_path, capsys):
    """Eight numbers for the nine Jenkins parameters of the BRB: exit 2, one line naming the option and the
    parameters expected, no output folder."""
    out = tmp_path / "epmc"
    status = surrogacy(["epmc", "--rom", str(beam_roms / "BRB.npz"), "--model", "jenkins", "--design",
                        "300,1e7,1e9,300,1e7,1e9,300,1e7", "--out", str(out)])
    assert status == 2
    error = capsys.readouterr().err
    assert "option --design" in error and "expected 9 finite numbers (F_S[0], K_T[0], K_z[0]" in error
    assert not out.exists()


def test_epmc_refuses_a_missing_superelement(tmp_path, capsys):
    """A --rom that is not a file: exit 2 naming it, nothing written."""
    out = tmp_path / "epmc"
    status = surrogacy(["epmc", "--rom", str(tmp_path / "absent.npz"), "--model", "jenkins", "--design",
                        JENKINS_DESIGN, "--out", str(out)])
    assert status == 2
    assert f"option --rom = {tmp_path / 'absent.npz'}: no such file" in capsys.readouterr().err
    assert not out.exists()


def test_epmc_refuses_a_design_whose_stuck_mode_is_unstable(beam_roms, tmp_path, capsys):
    """Joint springs of 100 N/m on the prestressed BRB: the stuck target mode has a negative stiffness, so there
    is no vibration to follow; exit 2 saying so, nothing written."""
    out = tmp_path / "epmc"
    status = surrogacy(["epmc", "--rom", str(beam_roms / "BRB.npz"), "--model", "jenkins", "--design",
                        "300,1e2,1e2,300,1e2,1e2,300,1e2,1e2", "--out", str(out)])
    assert status == 2
    assert "stuck target mode of this jenkins design has a negative stiffness" in capsys.readouterr().err
    assert not out.exists()
