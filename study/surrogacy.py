"""Confidence of surrogacy (paper section 4.4, Eq. 29, Table 5) with binomial confidence intervals.

A design is accepted by structure I when both of its L-infinity errors on I are within the bounds
(``study.errors.accepted``). The surrogacy coefficient of surrogate I for real structure J is the fraction of
the designs accepted by I that J accepts too,

    SC_IJ = n_IJ / n_I,    n_IJ = sum_n 1_I(x_n) 1_J(x_n),    n_I = n_II        (paper Eq. 29)

rows I surrogate, columns J real; SC_II = 1 and SC_IJ != SC_JI in general (surrogacy is one-way). Given n_I,
n_IJ is binomial with success probability SC_IJ, so each cell carries a binomial confidence interval
(Clopper-Pearson by default: never below its nominal coverage). Replicate populations (disjoint sets of
designs) give the spread of the estimate directly; the bounds sweep shows how SC moves as the acceptance box
moves (paper section 6: modifying the bounds "slowly perturbs" the estimates).

Tables: a long CSV (one row per model, surrogate and real structure) and Markdown in Table 5's layout, with
the paper's value beside ours where the paper gives one (its CSV is read from a path, never copied).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

import numpy as np
import pandas as pd
from statsmodels.stats.proportion import proportion_confint

from nonlinear.friction_models import friction_model
from pipeline.files import atomic_path
from pipeline.published import TABLE5
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ, accepted

CONFIDENCE_LEVEL = 0.95
INTERVAL_METHOD = "beta"  # Clopper-Pearson, statsmodels' name
TABLE_COLUMNS = ("model", "surrogate", "real", "confidence", "lower", "upper", "accepted_surrogate",
                 "accepted_both", "paper")


class SurrogacyMatrix(NamedTuple):
    """Surrogacy of S structures for one another (paper Eq. 29); leading axes (if any) index bounds or replicates.

    accepted_counts: (..., S) n_I, designs accepted by structure I; joint_counts: (..., S, S) n_IJ, accepted
    by I and J (diagonal n_I); confidence: (..., S, S) SC_IJ = n_IJ / n_I, rows surrogate I, columns real J,
    NaN where n_I = 0; lower, upper: (..., S, S) binomial confidence interval of SC_IJ, NaN where n_I = 0.
    """

    accepted_counts: np.ndarray
    joint_counts: np.ndarray
    confidence: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


class ReplicateSurrogacy(NamedTuple):
    """SC over R replicate populations.

    labels: (R,) replicate labels, sorted; accepted_counts: (R, S) n_I in each replicate; confidence: (R, S, S)
    SC_IJ of each replicate (NaN where that replicate's n_I = 0); mean, standard_deviation: (S, S) over the
    replicates with a value (standard deviation with R - 1 degrees of freedom).
    """

    labels: np.ndarray
    accepted_counts: np.ndarray
    confidence: np.ndarray
    mean: np.ndarray
    standard_deviation: np.ndarray


def joint_counts(accepted_designs) -> np.ndarray:
    """n_IJ = sum_n 1_I(x_n) 1_J(x_n) (paper Eq. 29) of accepted_designs (..., n_designs, S) bool: (..., S, S)
    int64, rows surrogate I, columns real J, diagonal n_I. Counts add over disjoint sets of designs, so a sample
    read in chunks has the sum of its chunks' counts."""
    indicator = np.asarray(accepted_designs, dtype=bool).astype(float)  # 1_I(x_n); sums exact below 2^53
    return np.rint(np.swapaxes(indicator, -1, -2) @ indicator).astype(np.int64)


def surrogacy_matrix(accepted_designs, level: float = CONFIDENCE_LEVEL,
                     method: str = INTERVAL_METHOD) -> SurrogacyMatrix:
    """SC_IJ = n_IJ / n_I (paper Eq. 29) of accepted_designs (n_designs, S) bool, with the two-sided binomial
    confidence interval at ``level`` of each cell (``matrix_from_counts``)."""
    return matrix_from_counts(joint_counts(accepted_designs), level, method)


def matrix_from_counts(joint_counts, level: float = CONFIDENCE_LEVEL, method: str = INTERVAL_METHOD) -> SurrogacyMatrix:
    """SurrogacyMatrix from n_IJ (..., S, S), whose diagonal is n_I: SC_IJ = n_IJ / n_I and the two-sided binomial
    confidence interval at ``level`` of each cell (``statsmodels.stats.proportion.proportion_confint``; method
    "beta" is Clopper-Pearson, "wilson", "jeffreys", ... as statsmodels names them)."""
    joint_counts = np.asarray(joint_counts, dtype=np.int64)
    counts = np.diagonal(joint_counts, axis1=-2, axis2=-1).copy()
    trials = np.broadcast_to(counts[..., :, None], joint_counts.shape)
    has_designs = trials > 0
    confidence = np.divide(joint_counts, trials, out=np.full(joint_counts.shape, np.nan), where=has_designs)
    lower, upper = proportion_confint(joint_counts, np.maximum(trials, 1), alpha=1.0 - level, method=method)
    lower, upper = (np.where(has_designs, bound, np.nan) for bound in (lower, upper))
    return SurrogacyMatrix(counts, joint_counts, confidence, lower, upper)


def replicate_joint_counts(accepted_designs, replicate) -> tuple[np.ndarray, np.ndarray]:
    """(labels (R,) sorted, n_IJ (R, S, S) of each replicate population) of accepted_designs (n_designs, S) bool
    and replicate (n_designs,) the integer label of the population each design belongs to."""
    accepted_designs = np.asarray(accepted_designs, dtype=bool)
    labels, population = np.unique(np.asarray(replicate), return_inverse=True)
    counts = [joint_counts(accepted_designs[population == index]) for index in range(labels.size)]
    shape = (0, accepted_designs.shape[1], accepted_designs.shape[1])
    return labels, np.stack(counts) if counts else np.zeros(shape, dtype=np.int64)


def replicate_surrogacy(accepted_designs, replicate) -> ReplicateSurrogacy:
    """SC of each replicate population and its mean and standard deviation over the replicates
    (``replicate_from_counts`` of ``replicate_joint_counts``).

    accepted_designs: (n_designs, S) bool; replicate: (n_designs,) integer label of the population each
    design belongs to (e.g. ``np.arange(n) % R`` for R interleaved LHS populations).
    """
    return replicate_from_counts(*replicate_joint_counts(accepted_designs, replicate))


def replicate_from_counts(labels, joint_counts) -> ReplicateSurrogacy:
    """SC of each replicate population from its counts n_IJ (R, S, S) (labels (R,)), and the mean and standard
    deviation over the replicates. The standard deviation is the replicate-to-replicate spread of one
    population's estimate, about sqrt(SC (1 - SC) / n_I)."""
    matrices = matrix_from_counts(joint_counts)
    with warnings.catch_warnings():  # a cell with fewer than two replicate values has no mean or spread: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(matrices.confidence, axis=0)
        spread = np.nanstd(matrices.confidence, axis=0, ddof=1)
    return ReplicateSurrogacy(np.asarray(labels), matrices.accepted_counts, matrices.confidence, mean, spread)


def bounds_joint_counts(frequency_error_hz, damping_error, frequency_bounds_hz, damping_bounds) -> np.ndarray:
    """n_IJ (a, b, S, S) at every pair of acceptance bounds: frequency_bounds_hz (a,) Hz, damping_bounds (b,) of
    the errors frequency_error_hz, damping_error (n_designs, S) (Hz, -; NaN where QSMA did not converge)."""
    frequency_bounds_hz = np.atleast_1d(np.asarray(frequency_bounds_hz, dtype=float))
    damping_bounds = np.atleast_1d(np.asarray(damping_bounds, dtype=float))
    n_structures = np.shape(frequency_error_hz)[-1]
    return np.array([[joint_counts(accepted(frequency_error_hz, damping_error, frequency_bound, damping_bound))
                      for damping_bound in damping_bounds] for frequency_bound in frequency_bounds_hz],
                    dtype=np.int64).reshape(frequency_bounds_hz.size, damping_bounds.size, n_structures,
                                            n_structures)


def surrogacy_against_bounds(frequency_error_hz, damping_error, frequency_bounds_hz, damping_bounds,
                             level: float = CONFIDENCE_LEVEL, method: str = INTERVAL_METHOD) -> SurrogacyMatrix:
    """SC for every pair of acceptance bounds: how the surrogacy moves as the acceptance box moves.

    frequency_error_hz, damping_error: (n_designs, S) L-infinity errors (Hz, -), NaN where QSMA did not
    converge; frequency_bounds_hz: (a,) Hz; damping_bounds: (b,). Returns a SurrogacyMatrix whose fields have
    leading axes (a, b): accepted_counts (a, b, S), joint_counts, confidence, lower, upper (a, b, S, S).
    """
    return matrix_from_counts(bounds_joint_counts(frequency_error_hz, damping_error, frequency_bounds_hz,
                                                  damping_bounds), level, method)


def plot_bounds_sensitivity(sweep: SurrogacyMatrix, frequency_bounds_hz, damping_bounds,
                            structures: Sequence[str], destination: Path,
                            frequency_tolerance_hz: float = FREQUENCY_TOLERANCE_HZ,
                            damping_tolerance: float = DAMPING_TOLERANCE, title: str = "") -> None:
    """PNG of each off-diagonal SC_IJ with its confidence band, written atomically: left against the frequency
    bound (Hz) at the damping bound nearest ``damping_tolerance``, right against the damping bound at the
    frequency bound nearest ``frequency_tolerance_hz``; the nominal bounds dashed.

    sweep: ``surrogacy_against_bounds`` over frequency_bounds_hz (a,) and damping_bounds (b,); structures: (S,)
    names in the order of the sweep's axes.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frequency_bounds_hz, damping_bounds = np.asarray(frequency_bounds_hz), np.asarray(damping_bounds)
    nominal_frequency = int(np.argmin(np.abs(frequency_bounds_hz - frequency_tolerance_hz)))
    nominal_damping = int(np.argmin(np.abs(damping_bounds - damping_tolerance)))
    panels = ((frequency_bounds_hz, np.s_[:, nominal_damping], frequency_tolerance_hz,
               f"frequency bound (Hz), damping bound {damping_bounds[nominal_damping]:.3g}"),
              (damping_bounds, np.s_[nominal_frequency, :], damping_tolerance,
               f"damping bound (-), frequency bound {frequency_bounds_hz[nominal_frequency]:.3g} Hz"))
    figure, axes = plt.subplots(1, 2, sharey=True, figsize=(10, 4))
    for axis, (bounds, cut, nominal, label) in zip(axes, panels):
        for surrogate, real in ((i, j) for i in range(len(structures)) for j in range(len(structures)) if i != j):
            cell = (cut[0], cut[1], surrogate, real)
            line, = axis.plot(bounds, sweep.confidence[cell], "o-", ms=3,
                              label=f"{structures[surrogate]} for {structures[real]}")
            axis.fill_between(bounds, sweep.lower[cell], sweep.upper[cell], color=line.get_color(), alpha=0.2)
        axis.axvline(nominal, color="k", ls="--", lw=0.8)
        axis.set_xlabel(label)
        axis.set_xscale("log")
    axes[0].set_ylabel("surrogacy confidence SC (surrogate for real)")
    axes[0].set_ylim(-0.02, 1.02)
    axes[1].legend(fontsize=8)
    figure.suptitle(title or "surrogacy against the acceptance bounds")
    figure.tight_layout()
    with atomic_path(destination) as temporary:
        figure.savefig(temporary, format="png", dpi=150)
    plt.close(figure)


def paper_surrogacy(table5: tuple = TABLE5) -> pd.DataFrame:
    """The paper's Table 5 (``pipeline.published.TABLE5``) as a DataFrame with columns model, surrogate, real,
    confidence."""
    return pd.DataFrame(list(table5), columns=["model", "surrogate", "real", "confidence"])


def surrogacy_table(matrices: Mapping[str, SurrogacyMatrix], structures: Sequence[str],
                    paper: pd.DataFrame | None = None) -> pd.DataFrame:
    """Long table of SC (``TABLE_COLUMNS``): one row per friction model, surrogate and real structure.

    matrices: friction model -> SurrogacyMatrix over the S structures named (in order) by ``structures``;
    paper: ``paper_surrogacy``; its value is matched on (model, surrogate, real), the model under its
    paper name (``nonlinear.friction_models.FrictionModel.paper_name``), NaN where the paper has none.
    """
    rows = [(model, structures[surrogate], structures[real], matrix.confidence[surrogate, real],
             matrix.lower[surrogate, real], matrix.upper[surrogate, real], matrix.accepted_counts[surrogate],
             matrix.joint_counts[surrogate, real])
            for model, matrix in matrices.items()
            for surrogate in range(len(structures)) for real in range(len(structures))]
    table = pd.DataFrame(rows, columns=list(TABLE_COLUMNS[:-1]))
    table["paper"] = np.nan
    if paper is not None:
        values = paper.set_index(["model", "surrogate", "real"])["confidence"]
        keys = zip(table["model"].map(lambda model: friction_model(model).paper_name or model), table["surrogate"],
                   table["real"])
        table["paper"] = [values.get(key, np.nan) for key in keys]
    return table


def write_surrogacy_csv(table: pd.DataFrame, destination: Path) -> None:
    """Write ``surrogacy_table`` as CSV (full precision, so reading it back gives the same numbers), atomically."""
    with atomic_path(destination) as temporary:
        table.to_csv(temporary, index=False, columns=list(TABLE_COLUMNS))


def surrogacy_cell(row) -> str:
    """One Table 5 cell: "SC [lower, upper] (n_IJ/n_I)", and the paper's value where it has one."""
    if row.accepted_surrogate == 0:
        text = "- (0/0)"
    else:
        text = (f"{row.confidence:.3f} [{row.lower:.3f}, {row.upper:.3f}] "
                f"({row.accepted_both}/{row.accepted_surrogate})")
    return text if np.isnan(row.paper) else f"{text}; paper {row.paper:.3f}"


def surrogacy_markdown(table: pd.DataFrame, level: float = CONFIDENCE_LEVEL, depth: int = 3) -> str:
    """Markdown in Table 5's layout from ``surrogacy_table``: per friction model (a heading of level ``depth``),
    rows surrogate (S), columns real (R), structures in the table's order."""
    sections = [f"Surrogacy confidence SC_IJ = n_IJ / n_I (paper Eq. 29) with its {100 * level:g} % binomial "
                "confidence interval and (n_IJ/n_I); rows surrogate S, columns real R.\n"]
    for model, rows in table.groupby("model", sort=False):
        structures = list(dict.fromkeys(rows["surrogate"]))
        cells = {(row.surrogate, row.real): surrogacy_cell(row) for row in rows.itertuples()}
        lines = [f"{'#' * depth} {model}", "", "| S \\ R | " + " | ".join(structures) + " |",
                 "|---" * (len(structures) + 1) + "|"]
        lines += [f"| {surrogate} | " + " | ".join(cells[surrogate, real] for real in structures) + " |"
                  for surrogate in structures]
        sections.append("\n".join(lines) + "\n")
    return "\n".join(sections)


def write_surrogacy_markdown(table: pd.DataFrame, destination: Path, level: float = CONFIDENCE_LEVEL) -> None:
    """Write ``surrogacy_markdown`` atomically."""
    with atomic_path(destination) as temporary:
        temporary.write_text(surrogacy_markdown(table, level))


def replicate_table(replicates: ReplicateSurrogacy, structures: Sequence[str], model: str,
                    linear_damping: float) -> pd.DataFrame:
    """The ANOVA's observations (paper Table 6, ``study.anova.surrogacy_anova``) of one friction model and
    linear damping zeta_0: one row per replicate, surrogate and real structure, columns replicate, model,
    linear_damping, surrogate, real, confidence (NaN where that replicate's surrogate accepted no design)."""
    n_structures = replicates.accepted_counts.shape[1]
    replicate, surrogate, real = np.meshgrid(replicates.labels, np.arange(n_structures), np.arange(n_structures),
                                             indexing="ij")
    names = np.asarray(structures)
    return pd.DataFrame({"replicate": replicate.ravel(), "model": model, "linear_damping": linear_damping,
                         "surrogate": names[surrogate.ravel()], "real": names[real.ravel()],
                         "confidence": replicates.confidence.ravel()})
