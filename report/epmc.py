"""The report's section on QSMA against the nonlinear mode by harmonic balance (EPMC, ``nonlinear.epmc``): how far
the frequency and damping every study number rests on are from the dynamics, for the studies' representative
designs of every friction model, read from the files ``python -m benchmarks.epmc_qsma --study DIR`` wrote
(``results/epmc/study_<dataset>.csv``, one row per design and level; ``make epmc``).

Per structure and model: the designs compared, the levels where both methods converged, the median and largest
relative differences |f_QSMA / f_EPMC - 1| and |zeta_QSMA / zeta_EPMC - 1| over those levels (the damping where
EPMC's exceeds ``DAMPING_FLOOR``: below it both are the stuck mode's zero to the solvers' tolerances), the share of
levels within 0.15 % and 5 %, and the harmonic counts the designs' convergence checks chose. The figure puts every
level's two differences against QSMA's largest slip ratio there (the regime: stuck, microslip, macroslip).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from study.figures import plt, save

DAMPING_FLOOR = 1e-6
"""EPMC damping ratio below which a level's relative damping difference is not counted (a stuck or nearly stuck
mode, zeta of the order of the solvers' tolerances)."""
FREQUENCY_BOUND, DAMPING_BOUND = 1.5e-3, 5e-2
"""The agreement asked of QSMA (docs/design.md section 5.2): 0.15 % in frequency, 5 % in damping."""
DIFFERENCE_FLOOR, SLIP_FLOOR = 1e-9, 1e-8
"""The figure's floors: relative differences (round-off) and slip ratios below them are drawn on the axis."""
COLUMNS = ("dataset", "structure", "model", "source", "design", "parameters", "amplitude", "slip_ratio", "qsma_frequency_hz",
           "qsma_damping", "qsma_converged", "epmc_frequency_hz", "epmc_damping", "epmc_converged", "harmonics",
           "harmonics_converged")
"""The columns of a comparison file the section reads."""


def read_comparisons(folder: Path) -> pd.DataFrame | None:
    """Every ``study_<dataset>.csv`` of ``folder`` in one table (None where there is none). A file without one of
    ``COLUMNS`` raises ValueError naming it and the column."""
    frames = []
    for path in sorted(Path(folder).glob("study_*.csv")):
        frame = pd.read_csv(path)
        missing = [column for column in COLUMNS if column not in frame.columns]
        if missing:
            raise ValueError(f"{path}: not an EPMC comparison: column {missing[0]!r} missing (rerun "
                             "`python -m benchmarks.epmc_qsma --study DIR`)")
        frames.append(frame)
    return pd.concat(frames, ignore_index=True) if frames else None


def level_differences(levels: pd.DataFrame) -> pd.DataFrame:
    """The levels where both methods converged, with their relative differences: frequency_difference
    |f_QSMA / f_EPMC - 1|, damping_difference |zeta_QSMA / zeta_EPMC - 1| (NaN where EPMC's zeta is below
    DAMPING_FLOOR)."""
    both = levels[levels.qsma_converged.astype(bool) & levels.epmc_converged.astype(bool)].copy()
    both["frequency_difference"] = np.abs(both.qsma_frequency_hz / both.epmc_frequency_hz - 1.0)
    damped = both.epmc_damping > DAMPING_FLOOR
    both["damping_difference"] = np.where(damped, np.abs(both.qsma_damping / both.epmc_damping - 1.0), np.nan)
    return both


def comparison_table(levels: pd.DataFrame) -> pd.DataFrame:
    """Per structure and model, in the order they appear: designs, levels compared (both converged) of all
    levels, median and largest frequency and damping differences, the share within FREQUENCY_BOUND and
    DAMPING_BOUND (a level without a counted damping difference counts on its frequency alone), the harmonic
    counts chosen (smallest and largest) and the designs whose check did not converge within its counts."""
    both = level_differences(levels)
    rows = []
    for (structure, model), group in levels.groupby(["structure", "model"], sort=False):
        compared = both[(both.structure == structure) & (both.model == model)]
        f, z = compared.frequency_difference, compared.damping_difference.dropna()
        within = (compared.frequency_difference <= FREQUENCY_BOUND) & ~(compared.damping_difference > DAMPING_BOUND)
        designs = group.drop_duplicates("parameters")
        harmonics = designs.harmonics.dropna()
        rows.append({"structure": structure, "model": model, "source": ", ".join(sorted(set(group.source))),
                     "designs": len(designs), "levels": f"{len(compared)} of {len(group)}",
                     "df median": f.median() if len(f) else np.nan, "df max": f.max() if len(f) else np.nan,
                     "dzeta median": z.median() if len(z) else np.nan, "dzeta max": z.max() if len(z) else np.nan,
                     "within": within.mean() if len(compared) else np.nan,
                     "harmonics": (f"{int(harmonics.min())}-{int(harmonics.max())}" if len(harmonics) and
                                   harmonics.min() != harmonics.max() else
                                   f"{int(harmonics.min())}" if len(harmonics) else "-"),
                     "not converged in harmonics": int((~designs.harmonics_converged.fillna(True)
                                                        .astype(bool)).sum())})
    return pd.DataFrame(rows)


def percent(value: float) -> str:
    """A relative difference in % to two significant digits ('-' for none)."""
    return "-" if not np.isfinite(value) else f"{100 * value:.2g} %"


def table_markdown(table: pd.DataFrame) -> list[str]:
    """The comparison table as Markdown lines."""
    lines = ["| structure | model | designs | levels compared | df/f median | df/f max | dzeta/zeta median | "
             "dzeta/zeta max | within 0.15 % and 5 % | harmonics | not converged in harmonics |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, row in table.iterrows():
        within = "-" if not np.isfinite(row.within) else f"{100 * row.within:.0f} %"
        lines.append(f"| {row.structure} | {row.model} ({row.source}) | {row.designs} | {row.levels} | "
                     f"{percent(row['df median'])} | {percent(row['df max'])} | {percent(row['dzeta median'])} | "
                     f"{percent(row['dzeta max'])} | {within} | {row.harmonics} | "
                     f"{row['not converged in harmonics']} |")
    return lines


def plot_differences(destination: Path, levels: pd.DataFrame) -> None:
    """Two panels against QSMA's largest slip ratio of the level: |df/f| and |dzeta/zeta| of every level both
    methods converged at, one colour per friction model, one marker per structure, the bounds dashed."""
    both = level_differences(levels)
    figure, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    models = list(dict.fromkeys(both.model))
    structures = list(dict.fromkeys(both.structure))
    markers = "osD^v<>"
    floor = DIFFERENCE_FLOOR
    for (model, structure), group in both.groupby(["model", "structure"], sort=False):
        style = dict(color=f"C{models.index(model)}", marker=markers[structures.index(structure) % len(markers)],
                     linestyle="none", alpha=0.75, markersize=5)
        slip = np.maximum(group.slip_ratio, SLIP_FLOOR)
        axes[0].plot(slip, np.maximum(group.frequency_difference, floor), **style)
        axes[1].plot(slip, np.maximum(group.damping_difference, floor), **style)
    for axis, bound, name in ((axes[0], FREQUENCY_BOUND, "|f_QSMA / f_EPMC - 1|"),
                              (axes[1], DAMPING_BOUND, "|zeta_QSMA / zeta_EPMC - 1|")):
        axis.axhline(bound, color="k", linestyle="--", linewidth=0.8)
        axis.axvline(1.0, color="0.6", linestyle=":", linewidth=0.8)
        axis.set(xscale="log", yscale="log", xlabel="QSMA's largest slip ratio of the level", ylabel=name)
        axis.grid(True, which="major", alpha=0.3)
    handles = [plt.Line2D([], [], color=f"C{i}", marker="o", linestyle="none", label=model)
               for i, model in enumerate(models)]
    handles += [plt.Line2D([], [], color="0.3", marker=markers[i % len(markers)], linestyle="none", label=name)
                for i, name in enumerate(structures)]
    axes[1].legend(handles=handles, fontsize=7, loc="lower right")
    figure.suptitle("QSMA against EPMC at the measured amplitudes of the studies' representative designs "
                    "(dashed: 0.15 %, 5 %)", fontsize=9)
    figure.tight_layout()
    save(figure, destination)


def epmc_section(results: Path, out: Path, number: int) -> list[str]:
    """Section ``number`` of the report: the table and figure (``report_epmc.png`` in ``out``) of the comparison
    files in ``results/epmc``, or a line saying the comparison was not run and how to run it."""
    lines = [f"## {number}. QSMA against the nonlinear mode by harmonic balance (EPMC)", ""]
    levels = read_comparisons(Path(results) / "epmc")
    if levels is None:
        return lines + [f"_EPMC comparison not run: `make epmc` (`python -m benchmarks.epmc_qsma --study "
                        f"results/study-<dataset>`) writes {Path(results) / 'epmc' / 'study_<dataset>.csv'} after "
                        "the studies; not part of `make demo` (9 min of CPU)_"]
    figure = Path(out) / "report_epmc.png"
    plot_differences(figure, levels)
    datasets = ", ".join(sorted(set(levels.dataset)))
    lines += [f"QSMA (every number of the studies) against EPMC (Krack 2015; harmonic balance with the friction "
              f"elements' sliders in time, `nonlinear.epmc`) on the representative designs of each study's sample "
              f"fronts ({datasets}; Table 3 designs for a model a study did not run), at the structures' measured "
              "amplitudes, neither with linear damping; each design's harmonic count chosen by its own "
              "convergence check (frequency within 1e-5, damping within 1e-3 between two counts). Damping "
              f"differences only where EPMC's zeta exceeds {DAMPING_FLOOR:g}. Read from "
              f"{Path(results) / 'epmc'}/study_<dataset>.csv (`make epmc`).", ""]
    lines += table_markdown(comparison_table(levels)) + [""]
    return lines + ["Every level both methods reached, against QSMA's largest slip ratio there (differences below 1e-9 "
                    "and slip ratios below 1e-8 drawn on the axes' floors):", "",
                    f"![QSMA against EPMC]({figure.name})", ""]
