"""The study on a case with a known answer: a synthetic measurement made by QSMA of a known true design on the
project's own beams (labelled virtual), explored with a Latin hypercube sample that also contains the truth.

- the truth lies in every structure's acceptance region, with errors at round-off;
- SC is 1 on the diagonal and in [0, 1] elsewhere;
- a constructed asymmetric case: structure B is structure A measured over the lower half of A's levels only, so
  every design A accepts B accepts (B's L-infinity is over a subset of the same points): A's acceptance region
  lies inside B's and SC_AB = 1, SC_BA = n_A / n_B exactly;
- bad input: a measured curve with NaNs, too few points, non-increasing amplitude, a negative damping ratio or a
  non-positive frequency; unknown friction model; bounds with min > max (Table 3 limits), with the file and field
  named and nothing written.
"""

import re
from dataclasses import replace

import numpy as np
import pytest

from experiment.backbone import Backbone, ModeBackbone
from experiment.backbone_files import read_backbone, write_backbone
from geometry.parameters import BEAM_NAMES
from nonlinear.condensation import joint_space
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import parameter_limits, parameter_names, to_unit
from study.datasets import dataset_structures, measurement_path
from study.designs import design_chunk, sample_parameters, unit_chunk
from study.errors import accepted, design_errors
from study.exploration import Exploration, Sample, StudyError, explore
from study.analysis import model_errors
from reduction.superelement import StructureError, beam_superelement, target_mode
from study.structures import BackboneLevels, measured_levels, qsma_measurement, structure
from study.surrogacy import surrogacy_matrix
from study.workflow import Paths

MODEL = "iwan4"
# A stiff, microslipping joint in BRB layout (groups {1,5}, {2,4}, {3}): per group F_S (N), K_T (N/m), chi,
# beta, K_z (N/m), inside paper Table 3.
TRUE_DESIGN = np.array([4e3, 2e8, -0.4, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 5e9, 8e3, 4e8, -0.5, 0.3, 5e9])
N_LEVELS = 12
ZETA0 = 1.6659e-3


@pytest.fixture(scope="module")
def beams(beam_roms):
    """BRB, LBRB, SBRB (prestressed) with synthetic measurements of the true design, and the BRB over the lower
    half of its levels only ('BRB low')."""
    structures = []
    for beam in BEAM_NAMES:
        superelement = beam_superelement(beam_roms / f"{beam}.npz")
        space = joint_space(superelement)
        levels = np.geomspace(1e-7, 3e-5, N_LEVELS)
        measured = qsma_measurement(space, beam, MODEL, TRUE_DESIGN, levels, ZETA0)
        structures.append(structure(beam, superelement, measured, 0.0, N_LEVELS))
    brb = structures[0]
    half = slice(N_LEVELS // 2)
    low = replace(brb.measurement, **{name: getattr(brb.measurement, name)[half] for name in (
        "amplitude", "frequency_hz", "damping", "frequency_uncertainty_hz", "damping_uncertainty")})
    return structures, replace(brb, name="BRB low", measurement=low)


def test_truth_lies_in_every_acceptance_region(beams):
    structures, _ = beams
    for structure_ in structures:
        errors = design_errors(structure_, MODEL, TRUE_DESIGN[None, :], [ZETA0])
        assert errors.converged[0]
        assert errors.frequency_error_hz[0] < 1e-9 * structure_.measurement.frequency_hz[0]
        assert errors.damping_error[0, 0] < 1e-9
        # the measured target mode is the first bending, chosen from the measured frequency
        assert target_mode(structure_.space.superelement, structure_.measurement.low_amplitude_frequency_hz)[0] == 0


def test_damping_rule_outside_the_joint_does_not_count_the_joints_damping_twice(beams):
    """The truth with zeta_0 outside the joint, and the damping case's value taken as the lowest measured level
    (as the ASB study does): added to the joint's damping (the paper's rule) the truth misses by the joint's own
    damping at that level; with the rule "outside_joint" it is exact again, and an "outside_joint" zeta_0 is
    never negative (a design whose joint damps more than the whole measured structure)."""
    from study.errors import structure_damping

    structures, _ = beams
    brb = structures[0]
    lowest = float(brb.measurement.damping[0])
    added = design_errors(brb, MODEL, TRUE_DESIGN[None, :], [lowest], rule="added")
    outside = design_errors(brb, MODEL, TRUE_DESIGN[None, :], [lowest], rule="outside_joint")
    joint_at_lowest = lowest - ZETA0  # the measurement is the truth's joint damping plus ZETA0
    assert joint_at_lowest > 1e-5  # a microslipping joint: enough to matter against the study's resolution
    assert added.damping_error[0, 0] == pytest.approx(joint_at_lowest, rel=1e-6)
    assert outside.damping_error[0, 0] < 1e-9
    assert np.all(structure_damping(np.array([[2e-3, 3e-3], [5e-4, 1e-3]]), [1e-3, 4e-3], "outside_joint")
                  == np.array([[0.0, 2e-3], [5e-4, 3.5e-3]]))
    with pytest.raises(ValueError, match="damping rule 'sum'"):
        structure_damping(np.zeros((1, 2)), [1e-3], "sum")


def test_surrogacy_of_the_known_truth_and_the_nested_regions(beams, tmp_path):
    structures, brb_low = beams
    exploration = Exploration((*structures, brb_low), (MODEL,), Sample(seed=7, n_designs=1200, chunk_size=400,
                                                                        n_replicates=3),
                              {"BRB": [ZETA0] * 4})
    explore(exploration, tmp_path, progress=False)
    errors = model_errors(tmp_path, MODEL, exploration.names, "BRB")
    truth = [design_errors(s, MODEL, TRUE_DESIGN[None, :], [ZETA0]) for s in exploration.structures]
    frequency = np.vstack([errors.frequency_error_hz, [[t.frequency_error_hz[0] for t in truth]]])
    damping = np.vstack([errors.damping_error, [[t.damping_error[0, 0] for t in truth]]])
    acceptance = accepted(frequency, damping)
    assert acceptance[-1].all()  # the truth, appended last
    matrix = surrogacy_matrix(acceptance)
    assert np.all(np.diag(matrix.confidence) == 1.0)
    assert np.all((matrix.confidence >= 0.0) & (matrix.confidence <= 1.0))
    # nested regions: everything the full BRB accepts, the BRB over its lower levels accepts
    brb, low = 0, 3
    assert np.all(acceptance[acceptance[:, brb], low])
    assert matrix.confidence[brb, low] == 1.0
    assert matrix.accepted_counts[low] > matrix.accepted_counts[brb]  # strictly larger here: a real asymmetry
    assert matrix.confidence[low, brb] == matrix.accepted_counts[brb] / matrix.accepted_counts[low]


def test_designs_are_a_latin_hypercube_within_table3():
    lower, upper, logarithmic = parameter_limits(MODEL, 3)
    designs = design_chunk(11, MODEL, 2, 250, 3)
    assert np.all((designs >= lower) & (designs <= upper))
    strata = np.floor(to_unit(designs, lower, upper, logarithmic) * 250).astype(int)
    for column in strata.T:  # one design in each of the 250 strata of every parameter
        assert np.array_equal(np.sort(column), np.arange(250))
    assert np.array_equal(designs, design_chunk(11, MODEL, 2, 250, 3))
    assert not np.array_equal(designs, design_chunk(11, MODEL, 3, 250, 3))
    assert len(parameter_names(MODEL, 3)) == designs.shape[1]


def test_models_share_the_samples_columns_of_the_parameters_they_share():
    """Common random numbers (``study.designs``): design i of a chunk has the same value of a parameter in every
    model that has it (F_S, K_T, K_z ...), so that models with the same stuck joint share its stuck modes; each
    model's sample is still a Latin hypercube of its own (the test above), and different parameters come from
    independent columns (the 210 pairwise correlations of 250 designs within 0.35, 5.5 of their standard error
    1 / sqrt(250))."""
    columns = {model: dict(zip(parameter_names(model, 3), design_chunk(11, model, 2, 250, 3).T))
               for model in MODEL_NAMES}
    every = {**columns["iwan5"], **columns["iwan4_core"]}
    for model in MODEL_NAMES:
        for name, values in columns[model].items():
            assert np.array_equal(values, every[name]), (model, name)
    unit = unit_chunk(11, 2, 250, 3)
    assert set(every) == set(sample_parameters(3)) and unit.shape == (250, len(every))
    correlation = np.corrcoef(unit.T)
    assert np.max(np.abs(correlation[np.triu_indices_from(correlation, 1)])) < 0.35


def backbone_with(amplitude, frequency, damping) -> ModeBackbone:
    nan = np.full(len(amplitude), np.nan)
    return ModeBackbone("X", 100.0, "m kg^0.5", "virtual", "test",
                        Backbone(np.asarray(amplitude, float), np.asarray(frequency, float), nan, nan,
                                 np.asarray(damping, float), nan, nan, np.ones(len(amplitude), dtype=int)))


@pytest.mark.parametrize("amplitude, frequency, field", [
    ([1e-6, 2e-6, 3e-6, 4e-6], [100.0, np.nan, 99.0, 98.0], "natural_frequency"),
    ([1e-6, 2e-6], [100.0, 99.0], "modal_amplitude"),
    ([1e-6, 3e-6, 2e-6, 4e-6], [100.0, 99.5, 99.0, 98.0], "modal_amplitude"),
])
def test_bad_measured_curves_are_refused_naming_file_and_field(tmp_path, amplitude, frequency, field):
    path = tmp_path / "X.csv"
    write_backbone(backbone_with(amplitude, frequency, np.full(len(amplitude), 1e-3)), path)
    with pytest.raises(StructureError, match=f"{path}.*{field}"):
        measured_levels(read_backbone(path), 3, str(path))


@pytest.mark.parametrize("frequency, damping, field", [
    ([100.0, 99.5, 99.0, 98.0], [1e-3, -2e-4, 1e-3, 1e-3], "damping_ratio"),
    ([100.0, 99.5, 0.0, 98.0], [1e-3, 1e-3, 1e-3, 1e-3], "natural_frequency"),
])
def test_out_of_range_measured_values_are_refused_naming_file_and_field(tmp_path, frequency, damping, field):
    """A negative damping ratio or a non-positive frequency in a measurement file is refused, naming the file,
    the field and the first value out of range."""
    path = tmp_path / "X.csv"
    write_backbone(backbone_with([1e-6, 2e-6, 3e-6, 4e-6], frequency, damping), path)
    with pytest.raises(StructureError, match=re.escape(f"{path}: field {field}: 1 value(s) out of range")):
        measured_levels(read_backbone(path), 3, str(path))


@pytest.mark.parametrize("amplitude, frequency, field", [
    ([1e-6, 2e-6, 3e-6], [100.0, np.nan, 99.0], "frequency_hz"),
    ([1e-6], [100.0], "amplitude"),
    ([1e-6, 3e-6, 2e-6], [100.0, 99.5, 99.0], "amplitude"),
])
def test_a_measurement_record_that_breaks_its_invariants_is_refused(amplitude, frequency, field):
    """The record the study and the loop read, made directly (not by ``measured_levels``): NaN values or fewer
    than three increasing amplitudes are refused naming its source and the field."""
    unknown = np.full(len(amplitude), np.nan)
    with pytest.raises(StructureError, match=f"ring.csv: field {field}"):
        BackboneLevels(np.array(amplitude), np.array(frequency), np.full(len(amplitude), 1e-3), unknown, unknown,
                       100.0, "measured", "ring.csv")


def test_unknown_model_and_inverted_bounds_are_refused(beams, tmp_path):
    structures, _ = beams
    with pytest.raises(StudyError, match="unknown friction model.*'coulomb'"):
        Exploration(tuple(structures), ("coulomb",), Sample(), {"BRB": [ZETA0] * 3})
    with pytest.raises(StudyError, match="damping case 'BRB'"):
        Exploration(tuple(structures), (MODEL,), Sample(), {"BRB": [ZETA0]})
    assert not any(tmp_path.iterdir())


def test_study_command_refuses_bad_configuration_and_missing_measurements(tmp_path, capsys, beam_roms):
    """The ``surrogacy study`` command: an unknown friction model or a non-positive bound is refused naming the
    source, section and field before anything is written; a structure without its measurement file is refused
    naming the file, and no design chunk is written."""
    from cli.console import main as surrogacy

    out = tmp_path / "study"
    assert surrogacy(["study", "--out", str(out), "--set", 'study.models=["coulomb"]']) == 2
    assert "field 'models'" in capsys.readouterr().err and not out.exists()
    assert surrogacy(["study", "--out", str(out), "--set", "acceptance.frequency_tolerance_hz=-1"]) == 2
    assert "frequency_tolerance_hz" in capsys.readouterr().err and not out.exists()
    assert surrogacy(["study", "--out", str(out), "--rom", str(beam_roms), "--steps", "explore"]) == 2
    error = capsys.readouterr().err
    assert "measurements/BRB.csv" in error and "missing" in error
    assert not (out / "designs").exists()


def test_study_command_refuses_an_unknown_compute_device_naming_file_and_field(tmp_path, capsys):
    """``[compute] device`` other than cpu or cuda in the configuration file: exit 2 before anything is written,
    one line naming the file, the section, the field and the devices expected."""
    from cli.console import main as surrogacy

    config, out = tmp_path / "study.toml", tmp_path / "study"
    config.write_text('[compute]\ndevice = "gpu"\n')
    assert surrogacy(["study", "--out", str(out), "--config", str(config)]) == 2
    error = capsys.readouterr().err.strip()
    assert (f"{config}: [compute] field 'device' = 'gpu': expected one of ('cpu', 'cuda')" in error
            and len(error.splitlines()) == 1), error
    assert not out.exists()


def test_study_prestress_option_chooses_the_beams_superelement(beams, beam_roms, tmp_path):
    """``study.prestress`` (default true) gives the structures the prestressed halves, whose free modes include the
    clamp's negative-stiffness rotations that only the joint holds; false gives the unstressed halves (none), with
    the same tied first bending to 1e-4."""
    structures, _ = beams
    for structure_ in structures:
        m = structure_.measurement
        write_backbone(replace(backbone_with(m.amplitude, m.frequency_hz, m.damping), structure=structure_.name,
                               low_amplitude_frequency_hz=float(m.frequency_hz[0])),
                       measurement_path(tmp_path / "measurements", structure_.name))
    inputs = Paths(tmp_path, beam_roms, tmp_path)  # the measurements in tmp_path/measurements
    chosen = {flag: dataset_structures("beams", inputs, N_LEVELS, flag)
              for flag in (True, False)}
    for stressed, unstressed in zip(chosen[True], chosen[False]):
        assert np.min(stressed.space.eigenvalues) < -(2 * np.pi * 10.0) ** 2
        assert np.min(unstressed.space.eigenvalues) == 0.0
        tied = [np.sqrt(s.space.reference @ (s.space.eigenvalues * s.space.reference)) for s in (stressed, unstressed)]
        assert tied[0] == pytest.approx(tied[1], rel=1e-4)
