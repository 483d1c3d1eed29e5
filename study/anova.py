"""Four-way analysis of variance of the surrogacy confidence (paper section 5.2.2, Table 6).

Main-effects linear model of SC over four categorical factors, fitted by least squares (statsmodels ``ols``):

    SC = mu + a_surrogate + b_real + c_model + d_zeta0 + residual

with the surrogate structure, the real structure, the friction model and the linear damping zeta_0 as factors,
one observation per cell and replicate population. The paper's design: 3 x 3 x 4 x 3 cells x 10 replicates =
1080 observations, factor degrees of freedom 2, 2, 3, 2 and 1070 residual. Type II sums of squares
(``anova_lm(typ=2)``): each factor's after the other three; in a balanced design they equal the sequential
(type I) sums of R's ``aov`` that the paper reports and add up to the total sum of squares.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import statsmodels.formula.api as smf
from statsmodels.stats.anova import anova_lm

from pipeline.files import atomic_path
from pipeline.published import TABLE6

FACTORS = {"surrogate": "surrogate_beam", "real": "real_beam", "model": "friction_model",
           "linear_damping": "linearized_zeta"}
"""Column of the observations -> factor name in Table 6 (``pipeline.published.TABLE6``)."""
TABLE_COLUMNS = ("factor", "df", "sum_sq", "mean_sq", "f_value", "p_value")


def surrogacy_anova(frame: pd.DataFrame) -> pd.DataFrame:
    """Table 6 of observations frame: columns confidence (SC, -) and the factors surrogate, real, model,
    linear_damping (treated as categorical whatever their dtype), one row per cell and replicate.

    Returns a DataFrame with ``TABLE_COLUMNS``, one row per factor (``FACTORS`` names) and a last row
    "residuals" (f_value, p_value NaN): df, sum of squares (-^2), mean square = sum_sq / df, F = mean square /
    residual mean square and its p-value, Pr(F(df, df_residual) > F). A factor observed at one level only (a study
    of one friction model) has no effect to test: it stays out of the model, and its row has df 0, sum of squares
    0 and the rest NaN.
    """
    varied = [column for column in FACTORS if frame[column].nunique() > 1]
    formula = "confidence ~ " + (" + ".join(f"C({column})" for column in varied) or "1")
    table = anova_lm(smf.ols(formula, data=frame).fit(), typ=2)
    table.index = [FACTORS[term[2:-1]] if term.startswith("C(") else "residuals" for term in table.index]
    table = table.rename(columns={"F": "f_value", "PR(>F)": "p_value"})
    constant = pd.DataFrame({"df": 0.0, "sum_sq": 0.0, "f_value": np.nan, "p_value": np.nan},
                            index=[FACTORS[column] for column in FACTORS if column not in varied])
    table = pd.concat([table, constant]).reindex([*FACTORS.values(), "residuals"])
    table["mean_sq"] = table["sum_sq"] / table["df"].where(table["df"] > 0)
    table["df"] = table["df"].round().astype(int)
    return table.rename_axis("factor").reset_index()[list(TABLE_COLUMNS)]


def paper_anova(table6: tuple = TABLE6) -> pd.DataFrame:
    """The paper's Table 6 (``pipeline.published.TABLE6``) as a DataFrame with ``TABLE_COLUMNS``; p_value kept as
    text (the paper writes "<2e-16"), a missing F value NaN."""
    frame = pd.DataFrame(list(table6), columns=list(TABLE_COLUMNS))
    frame["f_value"] = frame["f_value"].astype(float)
    return frame


def p_value_text(p_value: float) -> str:
    """A p-value as Table 6 prints it: three significant digits, "<2e-16" below R's double-precision floor."""
    if np.isnan(p_value):
        return ""
    return "<2e-16" if p_value < 2e-16 else f"{p_value:.3g}"


def anova_markdown(table: pd.DataFrame, paper: pd.DataFrame | None = None, left_out: int = 0) -> str:
    """Markdown of ``surrogacy_anova`` with the paper's Table 6 (``paper_anova``) beside it: for each
    column ours and the paper's, matched on the factor name. left_out: observations missing from the balanced
    design (a replicate's surrogate accepted no design, SC undefined), stated under the table."""
    paper_rows = {} if paper is None else {row.factor: row for row in paper.itertuples()}
    header = ("| factor | df | df (paper) | sum sq | sum sq (paper) | mean sq | mean sq (paper) | F | F (paper) "
              "| Pr(>F) | Pr(>F) (paper) |")
    lines = ["Four-way ANOVA of the surrogacy confidence (paper Table 6), ours beside the paper's.", "", header,
             "|---" * 11 + "|"]
    for row in table.itertuples():
        theirs = paper_rows.get(row.factor)
        ours = (f"{row.df}", f"{row.sum_sq:.4g}", "" if np.isnan(row.mean_sq) else f"{row.mean_sq:.4g}",
                "" if np.isnan(row.f_value) else f"{row.f_value:.4g}", p_value_text(row.p_value))
        reference = ("",) * 5 if theirs is None else (
            f"{theirs.df}", f"{theirs.sum_sq:g}", f"{theirs.mean_sq:g}",
            "" if np.isnan(theirs.f_value) else f"{theirs.f_value:g}", theirs.p_value)
        lines.append(f"| {row.factor} | " + " | ".join(f"{a} | {b}" for a, b in zip(ours, reference)) + " |")
    if left_out:
        lines += ["", f"{left_out} observations left out (SC undefined: the surrogate accepted no design of "
                      "that replicate); the design is unbalanced and the sums of squares are type II."]
    return "\n".join(lines) + "\n"


def write_anova_markdown(table: pd.DataFrame, destination: Path, paper: pd.DataFrame | None = None,
                         left_out: int = 0) -> None:
    """Write ``anova_markdown`` atomically, with the paper's Table 6 (``paper_anova``) beside it where given."""
    with atomic_path(destination) as temporary:
        temporary.write_text(anova_markdown(table, paper, left_out))
