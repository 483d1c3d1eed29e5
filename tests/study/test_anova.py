"""Four-way ANOVA of the surrogacy confidence (paper Table 6) on balanced synthetic data with known effects."""

import itertools

import numpy as np
import pandas as pd

from geometry.parameters import BEAM_NAMES
from study.anova import anova_markdown, paper_anova, surrogacy_anova, write_anova_markdown
from study.surrogacy import replicate_surrogacy, replicate_table

STRUCTURES = BEAM_NAMES
MODELS = ("jenkins", "iwan4", "iwan5", "iwan4_stuck")
LINEAR_DAMPING = (1.67e-3, 2.0e-3, 2.5e-3)
REPLICATES = 10


def balanced_observations(seed=0, noise=0.05):
    """3 x 3 x 4 x 3 cells x 10 replicates (1080 rows) of SC = 0.5 + surrogate effect + real effect + noise: the
    friction model and the linear damping have no effect."""
    rng = np.random.default_rng(seed)
    cells = list(itertools.product(STRUCTURES, STRUCTURES, MODELS, LINEAR_DAMPING, range(REPLICATES)))
    frame = pd.DataFrame(cells, columns=["surrogate", "real", "model", "linear_damping", "replicate"])
    surrogate_effect = frame.surrogate.map({"BRB": 0.3, "LBRB": 0.0, "SBRB": -0.3})
    real_effect = frame.real.map({"BRB": -0.1, "LBRB": 0.05, "SBRB": 0.05})
    frame["confidence"] = 0.5 + surrogate_effect + real_effect + noise * rng.standard_normal(len(frame))
    return frame


def test_known_effects_are_found_and_degrees_of_freedom_are_table6s():
    table = surrogacy_anova(balanced_observations()).set_index("factor")
    assert list(table.index) == ["surrogate_beam", "real_beam", "friction_model", "linearized_zeta", "residuals"]
    assert list(table.df) == [2, 2, 3, 2, 1070]
    assert table.p_value["surrogate_beam"] < 1e-6 and table.p_value["real_beam"] < 1e-6
    assert table.p_value["friction_model"] > 0.01 and table.p_value["linearized_zeta"] > 0.01
    assert np.isnan(table.f_value["residuals"]) and np.isnan(table.p_value["residuals"])
    np.testing.assert_allclose(table.mean_sq, table.sum_sq / table.df)


def test_sums_of_squares_add_up_and_match_the_one_way_between_group_sums():
    frame = balanced_observations(seed=1)
    table = surrogacy_anova(frame).set_index("factor")
    confidence = frame.confidence.to_numpy()
    total = np.sum((confidence - confidence.mean()) ** 2)
    np.testing.assert_allclose(table.sum_sq.sum(), total, rtol=1e-10)  # balanced: orthogonal factors

    def between_groups(column):
        """One-way between-group sum of squares: sum over levels of n_level (mean_level - mean)^2."""
        groups = [confidence[(frame[column] == level).to_numpy()] for level in frame[column].unique()]
        return sum(len(group) * (group.mean() - confidence.mean()) ** 2 for group in groups)

    between = {factor: between_groups(column) for column, factor in
               (("surrogate", "surrogate_beam"), ("real", "real_beam"), ("model", "friction_model"),
                ("linear_damping", "linearized_zeta"))}
    for factor, sum_of_squares in between.items():
        np.testing.assert_allclose(table.sum_sq[factor], sum_of_squares, rtol=1e-10)
    residual_mean_square = (total - sum(between.values())) / 1070
    np.testing.assert_allclose(table.f_value["surrogate_beam"], between["surrogate_beam"] / 2 / residual_mean_square,
                               rtol=1e-10)


def test_replicate_populations_feed_the_anova(tmp_path):
    """The observations from replicate_surrogacy of every model and linear damping form Table 6's design; the
    Markdown puts the paper's values beside ours."""
    rng = np.random.default_rng(2)
    frames = []
    for model, linear_damping in itertools.product(MODELS, LINEAR_DAMPING):
        designs = rng.random((REPLICATES * 400, 3)) < [0.5, 0.4, 0.3]
        replicates = replicate_surrogacy(designs, np.arange(len(designs)) % REPLICATES)
        frames.append(replicate_table(replicates, STRUCTURES, model, linear_damping))
    table = surrogacy_anova(pd.concat(frames, ignore_index=True))
    assert list(table.df) == [2, 2, 3, 2, 1070]
    write_anova_markdown(table, tmp_path / "table6.md", paper_anova())
    text = (tmp_path / "table6.md").read_text()
    assert "| surrogate_beam | 2 | 2 |" in text and "| 267.533 |" in text and "<2e-16 |" in text
    assert "| residuals | 1070 | 1070 |" in text


def test_undefined_observations_are_left_out_and_stated():
    frame = balanced_observations(seed=3)
    frame.loc[[5, 50, 500], "confidence"] = np.nan  # a replicate's surrogate accepted no design
    table = surrogacy_anova(frame)
    assert list(table.df) == [2, 2, 3, 2, 1067]
    assert "3 observations left out" in anova_markdown(table, left_out=3)


def test_paper_table6_as_a_frame():
    paper = paper_anova()
    assert list(paper.df) == [2, 2, 3, 2, 1070] and paper.p_value[0] == "<2e-16" and np.isnan(paper.f_value[4])


def test_a_study_of_one_friction_model_tests_the_other_three_factors():
    """A study of one model (``--set study.models=...``): the model factor has one level and no effect to test
    (df 0); the others are the three-way ANOVA's, whose sums of squares are the one-way between-group sums of
    the balanced design."""
    frame = balanced_observations(seed=2)
    frame = frame[frame.model == "iwan4"]
    table = surrogacy_anova(frame).set_index("factor")
    assert list(table.index) == ["surrogate_beam", "real_beam", "friction_model", "linearized_zeta", "residuals"]
    assert list(table.df) == [2, 2, 0, 2, 270 - 7]
    assert table.sum_sq["friction_model"] == 0.0 and np.isnan(table.p_value["friction_model"])
    confidence = frame.confidence.to_numpy()
    groups = [confidence[(frame.surrogate == level).to_numpy()] for level in STRUCTURES]
    between = sum(len(group) * (group.mean() - confidence.mean()) ** 2 for group in groups)
    np.testing.assert_allclose(table.sum_sq["surrogate_beam"], between, rtol=1e-10)
    assert table.p_value["surrogate_beam"] < 1e-6 and "| friction_model | 0 |" in anova_markdown(table.reset_index())
