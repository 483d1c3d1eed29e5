"""The EPMC comparison of a study's designs (``benchmarks.epmc_qsma``, ``make epmc``): each row it writes is QSMA
and EPMC of the design at the structure's measured amplitudes, as the two methods give them when called alone."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks.epmc_qsma import main, sampled_structure, study_rows
from experiment.backbone_files import read_asb_backbone
from locations import SHARED
from nonlinear.condensation import joint_space
from nonlinear.epmc import converged_harmonics, joint_system, nonlinear_mode
from nonlinear.qsma import qsma_reference
from reduction.superelement import beam_superelement, target_mode
from study.structures import qsma_measurement, structure

ASB_DATA = SHARED / "data"
DESIGN = np.array([300.0, 1e7, -0.5, 0.1, 1e9] * 3)  # iwan4 on the BRB: microslip at 5e-6 to 3e-4 m kg^0.5


def test_rows_are_qsma_and_epmc_at_the_measured_amplitudes(beam_roms):
    """A virtual BRB measurement at four amplitudes; three levels asked: the first, the last and the one between
    (indices 0, 2, 3). The rows' frequencies (Hz) and damping are qsma_reference's and nonlinear_mode's at the
    harmonic count converged_harmonics picks among 1 and 3 over those amplitudes, to the bit."""
    superelement = beam_superelement(beam_roms / "BRB.npz")
    measured = qsma_measurement(joint_space(superelement), "BRB", "iwan4", DESIGN, np.geomspace(5e-6, 3e-4, 4), 0.0)
    beam = structure("BRB", superelement, measured, 0.0)
    rows = study_rows(beam, "iwan4", "front", 7, DESIGN, 3, (1, 3))
    amplitudes = beam.measurement.amplitude[[0, 2, 3]]
    np.testing.assert_array_equal(rows.amplitude, amplitudes)
    qsma = qsma_reference(beam.space, "iwan4", DESIGN, amplitudes=amplitudes)
    system = joint_system(beam.space, "iwan4", DESIGN, lowest_amplitude=amplitudes[0])
    harmonics = converged_harmonics(system, amplitudes, (1, 3))
    mode = nonlinear_mode(system, amplitudes, harmonics.harmonics)
    np.testing.assert_array_equal(rows.qsma_frequency_hz, qsma.frequency / (2 * np.pi))
    np.testing.assert_array_equal(rows.qsma_damping, qsma.damping)
    np.testing.assert_array_equal(rows.epmc_frequency_hz, mode.frequency / (2 * np.pi))
    np.testing.assert_array_equal(rows.epmc_damping, mode.damping)
    assert (rows.harmonics == harmonics.harmonics).all() and rows.epmc_converged.all() and rows.qsma_converged.all()
    assert json.loads(rows.parameters.iloc[0]) == DESIGN.tolist() and (rows.design == 7).all()


def test_a_design_without_a_vibration_is_a_row_saying_so(beam_roms):
    """A joint too soft for the prestressed BRB (K_T = K_z = 100 N/m): no stuck mode of positive stiffness, so
    neither method runs; its rows say why."""
    superelement = beam_superelement(beam_roms / "BRB.npz")
    measured = qsma_measurement(joint_space(superelement), "BRB", "iwan4", DESIGN, np.geomspace(5e-6, 3e-4, 4), 0.0)
    beam = structure("BRB", superelement, measured, 0.0)
    soft = np.array([300.0, 1e2, -0.5, 0.1, 1e2] * 3)
    rows = study_rows(beam, "iwan4", "table3", -1, soft, 3, (1, 3))
    assert len(rows) == 3 and not rows.epmc_converged.any() and not rows.qsma_converged.any()
    assert (rows.note == "unstable stuck mode or no slipping element").all()


@pytest.mark.skipif(not (ASB_DATA / "asb-reduced-models").is_dir(), reason=f"no ASB data in {ASB_DATA}")
def test_an_asb_configuration_is_sampled_on_the_mode_its_measurement_saw():
    """``--structure "ASB CD1"``: the CD1 reduced model with every patch in one parameter group (one Table 3
    design is one joint), and the target the tied mode its measured backbone's low-amplitude frequency picks."""
    superelement, space = sampled_structure("ASB CD1", Path("build/rom"), ASB_DATA)
    assert set(superelement.patch_groups) == {0}
    measured = read_asb_backbone(ASB_DATA / "asb-backbones" / "ASB_CD1_20Nm_BB.mat")
    _, shape, _ = target_mode(superelement, measured.low_amplitude_frequency_hz)
    np.testing.assert_allclose(space.reference, joint_space(superelement, reference_mode=shape).reference)


def test_a_structure_whose_files_are_absent_is_skipped_saying_which(tmp_path, monkeypatch, capsys):
    """Without the ASB data, or for a name that is no structure, the sampling prints why and writes nothing."""
    out = tmp_path / "levels.csv"
    for name, said in (("ASB CD1", f"{tmp_path}/asb-backbones/ASB_CD1_20Nm_BB.mat: missing"),
                       ("ASB CD2", "ASB CD2: not a structure")):
        monkeypatch.setattr(sys, "argv", ["epmc_qsma", "--structure", name, "--data", str(tmp_path),
                                          "--out", str(out)])
        main()
        assert f"{name}: skipped: {said}" in capsys.readouterr().out
    assert not out.exists()
