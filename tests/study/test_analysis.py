"""The streamed analysis (``study.analysis.sample_counts``: one pass over a model's chunks) against the same
statistics of the whole sample in memory (``study.analysis.model_errors`` and the array functions of
``study.surrogacy`` and ``study.analysis``), on a synthetic exploration (``benchmarks.analysis``: the chunks'
schema, random errors rounded so that equal errors and equal designs occur, 5 % not converged, a last chunk
shorter than the others):

- the joint acceptance counts at the bounds, over the bounds sweep, per replicate population and damping case,
  and the ANOVA's observations, equal the counts of the concatenated arrays exactly;
- each structure's Pareto front equals the whole sample's, designs and order included (ties as well);
- the designs' parameters read back by index equal the rows of the whole parameter table;
- the report's reasons counted chunk by chunk equal pandas' counts of the whole column.
"""

import numpy as np
import pandas as pd
import pytest

from benchmarks.analysis import synthetic_exploration
from nonlinear.joint import parameter_names
from study.analysis import (anova_observations, design_rows, front_of, merged_front, model_errors, reason_counts,
                            sample_counts, sample_front)
from study.errors import accepted
from study.exploration import StudyError, read_exploration
from study.pareto import non_dominated
from study.report import flag_table
from study.surrogacy import (joint_counts, replicate_surrogacy, replicate_table, surrogacy_against_bounds,
                             surrogacy_matrix)

MODEL = "jenkins"
NAMES = ["A", "B", "C"]
CASES = ["low", "high"]
N_DESIGNS, CHUNK, REPLICATES = 2300, 400, 4
FREQUENCY_BOUND, DAMPING_BOUND = 2.0, 1e-3
SWEEP_FREQUENCY = FREQUENCY_BOUND * np.array([0.25, 1.0, 3.0])
SWEEP_DAMPING = DAMPING_BOUND * np.array([0.5, 1.0, 2.0, 5.0])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return synthetic_exploration(tmp_path_factory.mktemp("synthetic"), MODEL, N_DESIGNS, CHUNK, NAMES, CASES,
                                 REPLICATES, seed=3, resolution=0.25)


@pytest.fixture(scope="module")
def streamed(folder):
    return sample_counts(folder, MODEL, NAMES, CASES, "high", FREQUENCY_BOUND, DAMPING_BOUND, SWEEP_FREQUENCY,
                         SWEEP_DAMPING, plotted_designs=700, progress=False)


def test_streamed_counts_equal_the_whole_samples(folder, streamed):
    whole = model_errors(folder, MODEL, NAMES, "high")
    acceptance = accepted(whole.frequency_error_hz, whole.damping_error, FREQUENCY_BOUND, DAMPING_BOUND)
    assert streamed.n_designs == N_DESIGNS == len(whole.design)
    matrix = surrogacy_matrix(acceptance)
    assert 10 < matrix.accepted_counts.min() and matrix.accepted_counts.max() < N_DESIGNS / 2  # a real test
    np.testing.assert_array_equal(streamed.joint_counts, matrix.joint_counts)
    sweep = surrogacy_against_bounds(whole.frequency_error_hz, whole.damping_error, SWEEP_FREQUENCY, SWEEP_DAMPING)
    np.testing.assert_array_equal(streamed.bounds_joint_counts, sweep.joint_counts)
    np.testing.assert_array_equal(streamed.replicate_labels, np.arange(REPLICATES))
    for case in CASES:
        errors = model_errors(folder, MODEL, NAMES, case)
        replicates = replicate_surrogacy(accepted(errors.frequency_error_hz, errors.damping_error, FREQUENCY_BOUND,
                                                  DAMPING_BOUND), errors.replicate)
        np.testing.assert_array_equal(np.diagonal(streamed.replicate_joint_counts[case], axis1=1, axis2=2),
                                      replicates.accepted_counts)
        assert [joint_counts(accepted(errors.frequency_error_hz, errors.damping_error, FREQUENCY_BOUND,
                                      DAMPING_BOUND)[errors.replicate == label]).tolist()
                for label in range(REPLICATES)] == streamed.replicate_joint_counts[case].tolist()
    np.testing.assert_array_equal(streamed.replicate_joint_counts["high"].sum(axis=0), matrix.joint_counts)


def test_joint_counts_are_the_brute_force_pair_counts():
    rng = np.random.default_rng(5)
    designs = rng.uniform(size=(300, 4)) < [0.2, 0.5, 0.7, 0.0]
    brute = [[sum(bool(row[i] and row[j]) for row in designs) for j in range(4)] for i in range(4)]
    assert joint_counts(designs).tolist() == brute
    assert joint_counts(designs[:0]).tolist() == [[0] * 4] * 4


def test_anova_observations_equal_those_of_the_whole_sample(folder, streamed):
    expected = []
    for case in CASES:
        errors = model_errors(folder, MODEL, NAMES, case)
        expected.append(replicate_table(replicate_surrogacy(accepted(errors.frequency_error_hz, errors.damping_error,
                                                                     FREQUENCY_BOUND, DAMPING_BOUND),
                                                            errors.replicate), NAMES, MODEL, case))
    pd.testing.assert_frame_equal(anova_observations({MODEL: streamed}, NAMES),
                                  pd.concat(expected, ignore_index=True))


def dominates(first, second) -> np.ndarray:
    """(m, k) whether row i of first (m, 2) dominates row j of second (k, 2): no worse in both, better in one."""
    return (np.all(first[:, None] <= second[None], axis=2) & np.any(first[:, None] < second[None], axis=2))


def test_streamed_fronts_equal_the_whole_samples_ties_included(folder, streamed):
    whole = model_errors(folder, MODEL, NAMES, "high")
    for structure in range(len(NAMES)):
        expected = sample_front(whole, structure)
        for got, wanted in zip(streamed.fronts[structure], expected):
            np.testing.assert_array_equal(got, wanted)
        # the independent check: no design of the sample dominates a front design, and every design off the front
        # is dominated by one on it
        points = np.column_stack([whole.frequency_error_hz[:, structure], whole.damping_error[:, structure]])
        front = np.column_stack(expected[1:])
        assert not dominates(points[~np.isnan(points).any(axis=1)], front).any()
        off = ~np.isin(whole.design, expected.design) & ~np.isnan(points).any(axis=1)
        assert dominates(front, points[off]).any(axis=0).all()
    sizes = [len(front.design) for front in streamed.fronts]
    ties = [np.unique(front.frequency_error_hz).size < len(front.design) for front in streamed.fronts]
    assert min(sizes) > 3 and any(ties)  # fronts with equal errors on them: their order is checked above


def test_merging_fronts_in_any_split_gives_the_whole_front():
    rng = np.random.default_rng(8)
    errors = np.round(rng.lognormal(size=(500, 2)), 1)
    errors[rng.uniform(size=500) < 0.1, 1] = np.nan
    design = np.arange(500)
    front = front_of(design[:0], errors[:0, 0], errors[:0, 1])
    for block in np.split(design, [7, 8, 200, 201, 450]):
        front = merged_front(front, block, errors[block, 0], errors[block, 1])
    expected = front_of(design, errors[:, 0], errors[:, 1])
    assert all(np.array_equal(a, b) for a, b in zip(front, expected))
    assert set(front.design) == set(np.flatnonzero(non_dominated(errors)))


def test_plotted_designs_are_the_first_ones(folder, streamed):
    whole = model_errors(folder, MODEL, NAMES, "high")
    np.testing.assert_array_equal(streamed.plotted.design, np.arange(700))
    np.testing.assert_array_equal(streamed.plotted.frequency_error_hz, whole.frequency_error_hz[:700])
    np.testing.assert_array_equal(streamed.plotted.damping_error, whole.damping_error[:700])


def test_design_rows_read_back_the_rows_of_the_parameter_table(folder):
    names = parameter_names(MODEL, 3)
    table = read_exploration(folder, MODEL, ["design", *names]).set_index("design")
    designs = np.array([2299, 0, 401, 399, 400, 401, 1500])
    np.testing.assert_array_equal(design_rows(folder, MODEL, designs, names), table.loc[designs, names].to_numpy())
    with pytest.raises(StudyError, match=r"chunk-000005\.parquet: no row of design 2300"):
        design_rows(folder, MODEL, [2300], names)


def test_reasons_counted_by_chunk_equal_the_whole_columns(folder):
    frame = read_exploration(folder, MODEL, [f"reason[{name}]" for name in NAMES])
    n_designs, reasons = reason_counts(folder, MODEL, NAMES)
    assert n_designs == N_DESIGNS
    for name in NAMES:
        column = frame[f"reason[{name}]"].astype(str)
        assert reasons[name] == column[column != ""].value_counts().to_dict()
        assert sum(reasons[name].values()) > 50
    lines = flag_table(folder, [MODEL], NAMES)
    column = frame["reason[B]"].astype(str)
    counts = "; ".join(f"{reason}: {count}" for reason, count in column[column != ""].value_counts().items())
    assert lines[3] == f"| {MODEL} | B | {N_DESIGNS} | {(column != '').sum()} | {counts} |"
