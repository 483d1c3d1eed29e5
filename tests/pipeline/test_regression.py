"""End-to-end regression: key numbers of the default pipeline against values stored when they
were checked, so that a change that moves them fails loudly. Each tolerance says why it is what it is.

Stored on 2026-11-23 from the default meshes (build/, made by the pipeline's own stages), the superelements' and the
reference joint's numbers again on 2026-11-26 (every joint row tied: translations and the normal springs' rows on
the patch rotations; the reference joint on the prestressed BRB): the superelements'
tied first bending, the BRB's contact under the preload, the reference joint tuned on the BRB and its QSMA
backbone, the surrogacy counts of a small ASB study and a discrepancy verdict (the surrogacy of a known case is
asserted exactly in tests/study/test_study.py). These numbers were themselves checked elsewhere: the tied
frequencies against the full FE model (test_superelement, < 0.5 %), QSMA against the oracle and 40-digit
references (test_qsma_deep_macroslip), the virtual experiments against QSMA (test_virtual_experiment).
"""

import numpy as np
import pytest

from reduction.superelement import load_superelement, stuck_joint_modes
from discrepancy.loop import discrepancy_loop
from study.structures import measured_levels
from discrepancy.virtual_data import REFERENCE_DAMPING, REFERENCE_FREQUENCY_HZ, undeclared_backbone
from virtual_experiment.reference_joint import beam_space, reference_joint
from nonlinear.qsma_vectorised import qsma_designs

# Tied first and second flexible frequencies (Hz) of the unstressed superelements. Tolerance 1e-6 relative: the
# meshes and the reduction are deterministic (fixed Lanczos start, one sign convention); gmsh or LAPACK versions
# move them by ~1e-9 here, a mesh or physics change by 1e-3 or more.
TIED_HZ = {"BRB": (189.71908769, 220.27126324), "LBRB": (88.38676223, 99.21309485),
           "SBRB": (94.37010418, 163.7691572)}
# The BRB reference joint's K_T of patches {1, 5} (N/m) and its QSMA backbone at 1e-5, 5e-5, 2e-4 m kg^0.5 with
# Table 1's linear damping. Tolerance 1e-7: Brent's root to 1e-12 in log k_t and QSMA to 1e-10 leave far less.
REFERENCE_K_T = 4.30591675e8
QSMA_HZ = (169.01555404, 168.34529807, 166.7183097)
QSMA_DAMPING = (0.00239677, 0.00356929, 0.00701288)


def test_tied_frequencies_of_the_default_superelements(beam_roms):
    for beam, expected in TIED_HZ.items():
        frequencies, _ = stuck_joint_modes(load_superelement(beam_roms / f"{beam}.npz"), 2)
        np.testing.assert_allclose(frequencies, expected, rtol=1e-6, err_msg=beam)


def test_reference_joint_and_its_backbone(beam_roms):
    space = beam_space(beam_roms / "BRB.npz", 169.48)
    design = reference_joint(space, 169.48)
    assert design[1] == pytest.approx(REFERENCE_K_T, rel=1e-7)
    result = qsma_designs(space, "iwan4", design[None, :], amplitudes=np.array([1e-5, 5e-5, 2e-4]),
                          linear_damping=1.665934e-3)
    np.testing.assert_allclose(result.frequency[0] / (2 * np.pi), QSMA_HZ, rtol=1e-7)
    np.testing.assert_allclose(result.damping[0], QSMA_DAMPING, rtol=1e-5)  # stored to 5 significant digits


def test_discrepancy_verdict_on_a_fixed_seed():
    """Microslip and a structure-specific damping put in (seed 3): the verdict names both. A change in the
    fit, the criterion or the library that loses one fails here."""
    measurement = measured_levels(undeclared_backbone(("microslip", "linear_damping"), seed=3))
    verdict = discrepancy_loop(measurement, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING)
    assert sorted(verdict.effects) == ["linear_damping", "microslip"]


# BRB preload on the default mesh: interface nodes in contact out of 1843, and the peak contact pressure (Pa).
# Tolerances: the count exactly (the active set of a deterministic solve); the pressure 1e-6 (as the frequencies).
CONTACT_NODES = 1203
PEAK_PRESSURE_PA = 3.849967534e7


def test_contact_of_the_default_brb(beam_roms):
    """The interface carries the three bolts' preload (equilibrium, to round-off of the sum), on the stored set
    of nodes with the stored peak pressure."""
    import json

    from fem.bolts import Bolt

    fe = beam_roms.parent / "fe"
    model = np.load(fe / "BRB.npz")
    assert model["contact_force"].sum() == pytest.approx(3 * Bolt().preload, rel=1e-12)
    assert int(model["contact_active"].sum()) == CONTACT_NODES
    peak = json.loads((fe / "BRB.json").read_text())["contact_pressure_range_pa"][1]
    assert peak == pytest.approx(PEAK_PRESSURE_PA, rel=1e-6)


# Joint counts n_IJ of the ASB's six configurations (C1, C2, C3, C4, C4a, CD1) for 4,000 iwan4 designs, seed 2024,
# the study's default bounds and damping. Exactly: a count moves only when a design's error crosses a bound, which
# round-off (1e-9 relative) does with a probability of about 1e-5 over these 24,000 errors; a change of the
# sample, the QSMA, the levels or the errors moves many.
ASB_JOINT_COUNTS = [[88, 75, 81, 11, 48, 2], [75, 218, 77, 81, 76, 2], [81, 77, 91, 7, 55, 2],
                    [11, 81, 7, 106, 14, 0], [48, 76, 55, 14, 1051, 34], [2, 2, 2, 0, 34, 37]]


def test_surrogacy_counts_of_a_small_asb_study(tmp_path):
    from cli.console import main as surrogacy
    from study.analysis import model_errors
    from study.datasets import dataset
    from study.errors import accepted
    from study.surrogacy import surrogacy_matrix
    from locations import ASB_MODELS

    data = ASB_MODELS.parent
    if not (data / "asb-backbones").is_dir():
        pytest.skip(f"ASB data not available at {data} (shared data folder absent)")
    out = tmp_path / "study"
    assert surrogacy(["study", "--out", str(out), "--data", str(data), "--set", "study.dataset=asb",
                      "--set", "sample.n_designs=4000", "--set", "sample.chunk_size=1000",
                      "--set", 'study.models=["iwan4"]', "--steps", "measurements", "explore"]) == 0
    errors = model_errors(out / "designs", "iwan4", list(dataset("asb").structures), "measured")
    matrix = surrogacy_matrix(accepted(errors.frequency_error_hz, errors.damping_error, 2.0, 0.005))
    np.testing.assert_array_equal(matrix.joint_counts, ASB_JOINT_COUNTS)
