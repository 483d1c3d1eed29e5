"""Confidence of surrogacy (paper Eq. 29, Table 5): exact counts on constructed acceptance regions, binomial
intervals and their coverage, replicate spread, the acceptance-bounds sweep, and the tables read back."""


import numpy as np
import pandas as pd
from scipy import stats

from geometry.parameters import BEAM_NAMES
from study.errors import accepted
from study.surrogacy import (paper_surrogacy, replicate_surrogacy, replicate_table, surrogacy_against_bounds,
                             surrogacy_markdown, surrogacy_matrix, surrogacy_table, plot_bounds_sensitivity,
                             write_surrogacy_csv, write_surrogacy_markdown)

STRUCTURES = BEAM_NAMES


def nested_regions(n=1000):
    """Designs x_k = (k + 1/2) / n; A accepts x < 0.2, B accepts x < 0.5 (A inside B), C accepts 0.4 <= x < 0.9."""
    x = (np.arange(n) + 0.5) / n
    return np.column_stack([x < 0.2, x < 0.5, (x >= 0.4) & (x < 0.9)])


def test_acceptance_region_inside_another_is_a_perfect_surrogate_but_not_conversely():
    matrix = surrogacy_matrix(nested_regions())
    np.testing.assert_array_equal(matrix.accepted_counts, [200, 500, 500])
    assert matrix.confidence[0, 1] == 1.0  # every design A accepts, B accepts
    assert matrix.confidence[1, 0] == 200 / 500  # |A| / |B|
    assert matrix.confidence[0, 2] == 0.0 and matrix.confidence[2, 0] == 0.0
    assert matrix.confidence[1, 2] == matrix.confidence[2, 1] == 100 / 500
    np.testing.assert_array_equal(np.diag(matrix.confidence), 1.0)
    np.testing.assert_array_equal(np.diag(matrix.joint_counts), matrix.accepted_counts)
    assert np.all((matrix.confidence >= 0) & (matrix.confidence <= 1))
    assert np.all((matrix.lower <= matrix.confidence) & (matrix.confidence <= matrix.upper))
    assert np.all((matrix.lower >= 0) & (matrix.upper <= 1))


def test_a_structure_accepting_nothing_has_no_surrogacy_row():
    designs = nested_regions()
    designs[:, 0] = False
    matrix = surrogacy_matrix(designs)
    assert np.isnan(matrix.confidence[0]).all() and np.isnan(matrix.lower[0]).all() and np.isnan(matrix.upper[0]).all()
    np.testing.assert_array_equal(matrix.confidence[1:, 0], 0.0)  # as a real structure it accepts none of theirs


def test_unconverged_designs_are_never_accepted():
    frequency_error = np.array([[0.5, 0.5], [np.nan, 0.5], [0.5, np.nan], [3.0, 0.5]])  # Hz
    damping_error = np.array([[1e-3, 1e-3], [1e-3, 1e-3], [np.nan, 1e-3], [1e-3, 1e-3]])
    matrix = surrogacy_matrix(accepted(frequency_error, damping_error))
    np.testing.assert_array_equal(matrix.accepted_counts, [1, 3])
    np.testing.assert_array_equal(matrix.joint_counts, [[1, 1], [1, 3]])


def accepted_with_count(n, k):
    """n designs all accepted by the surrogate, the first k by the real structure: SC = k / n."""
    return np.column_stack([np.ones(n, dtype=bool), np.arange(n) < k])


def test_interval_contains_the_estimate_and_shrinks_as_one_over_root_n():
    proportion = 0.3
    sizes = np.array([100, 400, 1600, 6400])
    widths = []
    for n in sizes:
        matrix = surrogacy_matrix(accepted_with_count(n, int(proportion * n)))
        assert matrix.lower[0, 1] < matrix.confidence[0, 1] == proportion < matrix.upper[0, 1]
        widths.append(matrix.upper[0, 1] - matrix.lower[0, 1])
    scaled = np.array(widths) * np.sqrt(sizes)
    normal_width = 2 * stats.norm.ppf(0.975) * np.sqrt(proportion * (1 - proportion))  # Wald, large n
    np.testing.assert_allclose(scaled, normal_width, rtol=0.06)
    assert np.all(np.diff(scaled) < 0)  # Clopper-Pearson is conservative, less so as n grows


def covers(matrix, proportion):
    """Whether the interval of the surrogate-for-real cell (0, 1) contains proportion."""
    return matrix.lower[0, 1] <= proportion <= matrix.upper[0, 1]


def test_clopper_pearson_covers_a_known_proportion_at_least_at_its_level():
    true_proportion, n, level, samples = 0.2, 50, 0.95, 1000
    exact = sum(stats.binom.pmf(k, n, true_proportion)
                * covers(surrogacy_matrix(accepted_with_count(n, k), level=level), true_proportion)
                for k in range(n + 1))  # over the binomial distribution of n_IJ
    assert exact >= level
    rng = np.random.default_rng(7)
    simulated = np.mean([covers(surrogacy_matrix(np.column_stack([np.ones(n, dtype=bool),
                                                                  rng.random(n) < true_proportion]), level=level),
                                true_proportion)
                         for _ in range(samples)])
    assert simulated >= level - 3 * np.sqrt(level * (1 - level) / samples)  # within 3 Monte-Carlo errors


def test_replicate_spread_matches_the_binomial_standard_error():
    rng = np.random.default_rng(3)
    n_replicates, per_replicate = 40, 1000
    surrogate = rng.random(n_replicates * per_replicate) < 0.4
    real = np.where(surrogate, rng.random(surrogate.size) < 0.7, rng.random(surrogate.size) < 0.5)
    designs = np.column_stack([surrogate, real])
    replicates = replicate_surrogacy(designs, np.arange(surrogate.size) % n_replicates)
    assert replicates.confidence.shape == (n_replicates, 2, 2)
    np.testing.assert_array_equal(replicates.accepted_counts.sum(axis=0), designs.sum(axis=0))
    pooled = surrogacy_matrix(designs).confidence[0, 1]
    standard_error = np.sqrt(pooled * (1 - pooled) / replicates.accepted_counts[:, 0].mean())
    # the sample standard deviation of 40 values is within 30 % (about 2.7 of its own standard errors)
    assert 0.7 < replicates.standard_deviation[0, 1] / standard_error < 1.3
    assert abs(replicates.mean[0, 1] - pooled) < 3 * standard_error / np.sqrt(n_replicates)
    np.testing.assert_array_equal(replicates.standard_deviation[[0, 1], [0, 1]], 0.0)


def test_replicate_table_lists_every_replicate_cell():
    designs = nested_regions(300)
    replicates = replicate_surrogacy(designs, np.arange(300) % 3)
    table = replicate_table(replicates, STRUCTURES, "iwan4", 1.67e-3)
    assert len(table) == 3 * 3 * 3
    row = table[(table.replicate == 2) & (table.surrogate == "LBRB") & (table.real == "BRB")]
    assert row.confidence.item() == replicates.confidence[2, 1, 0]


def random_errors(n=2000, seed=11):
    """L-infinity errors (n, 3) of designs on three structures, frequency (Hz) and damping; every 10th design
    unconverged on every structure, every 7th on the last only."""
    rng = np.random.default_rng(seed)
    frequency_error = rng.lognormal(np.log(3.0), 1.0, (n, 3))
    damping_error = rng.lognormal(np.log(5e-3), 1.0, (n, 3))
    frequency_error[::10] = np.nan
    damping_error[::7, 2] = np.nan
    return frequency_error, damping_error


def test_loosening_the_bounds_never_loses_an_accepted_design():
    frequency_error, damping_error = random_errors()
    frequency_bounds = np.array([0.5, 1.0, 2.0, 4.0, 8.0, np.inf])
    damping_bounds = np.array([1e-3, 5e-3, 2e-2, np.inf])
    sweep = surrogacy_against_bounds(frequency_error, damping_error, frequency_bounds, damping_bounds)
    assert sweep.confidence.shape == (6, 4, 3, 3) and sweep.accepted_counts.shape == (6, 4, 3)
    for axis in (0, 1):
        assert np.all(np.diff(sweep.accepted_counts, axis=axis) >= 0)
        assert np.all(np.diff(sweep.joint_counts, axis=axis) >= 0)
    nominal = surrogacy_matrix(accepted(frequency_error, damping_error, 2.0, 5e-3))
    np.testing.assert_array_equal(sweep.joint_counts[2, 1], nominal.joint_counts)
    np.testing.assert_array_equal(sweep.confidence[2, 1], nominal.confidence)
    # unbounded: every converged design accepted; SC = 1 between the first two (same converged designs), and
    # the third (fewer converged) keeps only its converged fraction as a real structure
    unbounded = sweep.confidence[-1, -1]
    converged = ~np.isnan(frequency_error) & ~np.isnan(damping_error)
    np.testing.assert_array_equal(sweep.accepted_counts[-1, -1], converged.sum(axis=0))
    np.testing.assert_array_equal(unbounded[:2, :2], 1.0)
    np.testing.assert_array_equal(unbounded[2], 1.0)
    assert unbounded[0, 2] == converged[:, 2].sum() / converged[:, 0].sum()


def test_bounds_plot_is_written(tmp_path):
    frequency_error, damping_error = random_errors(500)
    frequency_bounds, damping_bounds = np.geomspace(0.5, 20, 5), np.geomspace(1e-3, 5e-2, 4)
    sweep = surrogacy_against_bounds(frequency_error, damping_error, frequency_bounds, damping_bounds)
    destination = tmp_path / "bounds.png"
    plot_bounds_sensitivity(sweep, frequency_bounds, damping_bounds, STRUCTURES, destination, title="iwan4")
    assert destination.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [path.name for path in tmp_path.iterdir()] == ["bounds.png"]  # no temporary file left


def two_model_table(paper=None):
    rng = np.random.default_rng(5)
    designs = rng.random((400, 3)) < [0.3, 0.5, 0.6]
    empty_row = designs.copy()
    empty_row[:, 2] = False
    matrices = {"jenkins": surrogacy_matrix(designs), "iwan4_stuck": surrogacy_matrix(empty_row)}
    return matrices, surrogacy_table(matrices, STRUCTURES, paper)


def test_csv_read_back_equals_the_matrices(tmp_path):
    paper = pd.DataFrame({"model": ["jenkins", "iwan4_middle_stuck"], "surrogate": ["BRB", "LBRB"],
                          "real": ["LBRB", "BRB"], "confidence": [0.985275, 0.355002]})
    matrices, table = two_model_table(paper)
    write_surrogacy_csv(table, tmp_path / "surrogacy.csv")
    read = pd.read_csv(tmp_path / "surrogacy.csv")
    assert list(read.columns) == ["model", "surrogate", "real", "confidence", "lower", "upper",
                                  "accepted_surrogate", "accepted_both", "paper"]
    for model, matrix in matrices.items():
        rows = read[read.model == model]
        for field, column in (("confidence", "confidence"), ("lower", "lower"), ("upper", "upper"),
                              ("joint_counts", "accepted_both")):
            cells = rows.pivot(index="surrogate", columns="real", values=column).loc[list(STRUCTURES),
                                                                                      list(STRUCTURES)]
            np.testing.assert_array_equal(cells.to_numpy(), getattr(matrix, field))
        np.testing.assert_array_equal(rows.groupby("surrogate", sort=False).accepted_surrogate.first(),
                                      matrix.accepted_counts)
    assert read.paper.notna().sum() == 2  # the stuck model matched under its paper name
    assert read.set_index(["model", "surrogate", "real"]).paper["iwan4_stuck", "LBRB", "BRB"] == 0.355002


def test_markdown_has_table5_layout(tmp_path):
    paper = pd.DataFrame({"model": ["jenkins"], "surrogate": ["BRB"], "real": ["LBRB"], "confidence": [0.985275]})
    matrices, table = two_model_table(paper)
    text = surrogacy_markdown(table)
    assert text.count("| S \\ R | BRB | LBRB | SBRB |") == 2
    brb_lbrb = table.iloc[1]
    assert (f"| BRB | 1.000 [{matrices['jenkins'].lower[0, 0]:.3f}, 1.000] ({brb_lbrb.accepted_surrogate}/"
            f"{brb_lbrb.accepted_surrogate}) | {brb_lbrb.confidence:.3f} [") in text
    assert "; paper 0.985 |" in text
    assert "| SBRB | - (0/0) | - (0/0) | - (0/0) |" in text  # the stuck model's empty row
    write_surrogacy_markdown(table, tmp_path / "table5.md")
    assert (tmp_path / "table5.md").read_text() == text


def test_paper_table5_is_matched_for_every_model():
    paper = paper_surrogacy()
    _, table = two_model_table(paper)
    assert len(paper) == 36 and table.paper.notna().all()
