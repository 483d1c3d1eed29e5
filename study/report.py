"""The study's report in Markdown (paper Figs. 6, 9-12, Tables 5-6), section by section, from the study's records:
its exploration's manifest (structures, target modes, damping cases), the virtual experiments' lowest-amplitude
frequencies, the designs not converged (counted from the chunks), each friction model's surrogacy table (from its
CSV) and figures, the ANOVA and the prestress comparison as the analysis wrote them.

The sections take the depth of the study's heading (1 in the study's own ``report.md``, one more where another
report holds the study) and the folder their figure links start from; a figure absent is named, never linked.
:func:`write_report` writes the study's own ``<out>/report.md``; the pipeline report (``report.studies``) calls
:func:`study_lines` on the same records.
"""

from __future__ import annotations

import contextlib
import csv
import os
from pathlib import Path

import pandas as pd

from pipeline.files import atomic_path, json_text
from study.analysis import reason_counts
from study.exploration import manifest
from study.surrogacy import surrogacy_markdown


def relative_link(target: Path, start: Path) -> str:
    """``target`` relative to the folder ``start``, with forward slashes (Markdown links)."""
    return Path(os.path.relpath(Path(target).resolve(), Path(start).resolve())).as_posix()


def image_line(target: Path, caption: str, base: Path, ran: bool = True) -> str:
    """A Markdown image line for the figure ``target``, linked relative to the folder ``base``; where the file is
    absent, a line saying so instead: not written where its stage did not run (``ran`` false), missing where it
    did (deleted, or not drawn). Never a broken link."""
    if Path(target).exists():
        return f"![{caption}]({relative_link(target, base)})"
    if not ran:
        return f"_{caption}: {target} not written (stage not run)_"
    return (f"_{caption}: figure missing: {target} is absent although its stage ran (deleted, or not drawn: rerun "
            "the stage to draw it)_")


def heading(depth: int, text: str) -> str:
    """A Markdown heading of level ``depth`` (1: ``#``)."""
    return f"{'#' * depth} {text}"


def unchecked(path: Path, what: str):
    """Reading a record without naming it where it is damaged (the study reading the records it just wrote)."""
    return contextlib.nullcontext()


def low_amplitude_markdown(path: Path) -> list[str]:
    """The virtual experiments' lowest-amplitude frequency of each beam against paper Table 1 (Hz, and their
    difference in %), from their ``low_amplitude.csv`` (``virtual_experiment.hammer_test``), as Markdown rows
    under their header."""
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    return ["| beam | virtual (Hz) | Table 1 (Hz) | difference (%) |", "|---|---|---|---|",
            *(f"| {row['beam']} | {float(row['virtual_hz']):.2f} | {float(row['table1_hz']):.2f} | "
              f"{float(row['difference_percent']):+.2f} |" for row in rows)]


def flag_table(designs: Path, models, names) -> list[str]:
    """Markdown table of designs not converged, per model and structure, by reason (most frequent first),
    counted chunk by chunk (``study.analysis.reason_counts``)."""
    lines = ["| model | structure | designs | not converged | reasons |", "|---|---|---|---|---|"]
    for model in models:
        n_designs, reasons = reason_counts(designs, model, names)
        for name in names:
            ranked = sorted(reasons[name].items(), key=lambda item: -item[1])
            counts = "; ".join(f"{reason}: {count}" for reason, count in ranked)
            lines.append(f"| {model} | {name} | {n_designs} | {sum(reasons[name].values())} | {counts or '-'} |")
    return lines


def structures_lines(structures: list[dict], measurements: Path, depth: int) -> list[str]:
    """The study's structures (the manifest's records: provenance, the target mode chosen, the source of the
    measurement), a virtual study said so first, and the virtual experiments' lowest-amplitude frequencies against
    Table 1 where ``measurements`` holds them; headings below the study's at ``depth``."""
    lines = []
    if any(s["provenance"] == "virtual" for s in structures):
        lines += ["**The measurements of this study are VIRTUAL**: simulated ring-downs of one reference joint "
                  "(see measurements/<beam>_experiment.json), processed like measured data. They are not the "
                  "paper's measured curves, which are not public.", ""]
    lines += [heading(depth + 1, "Structures and target modes"), "", "| structure | provenance | target mode | source |",
              "|---|---|---|---|",
              *(f"| {s['name']} | {s['provenance']} | {s['mode_choice']} | {s['source']} |" for s in structures)]
    low_amplitude = measurements / "low_amplitude.csv"
    if low_amplitude.exists():
        lines += ["", heading(depth + 2, "Low-amplitude frequencies of the virtual experiments against paper Table 1"),
                  "", *low_amplitude_markdown(low_amplitude)]
    return lines


def sample_lines(parameters: dict, explored: dict, designs: Path, depth: int) -> list[str]:
    """The sample (designs, chunks, replicates, seed), levels, models, acceptance bounds (Hz, -), the linear
    damping cases with the rule that makes them each design's zeta_0, and the designs not converged in the chunks
    of ``designs``; headings below the study's at ``depth``."""
    study, sample, acceptance = parameters["study"], parameters["sample"], parameters["acceptance"]
    return [heading(depth + 1, "Sample"), "",
            f"{sample.n_designs} designs per friction model (replicated Latin hypercube over paper Table 3, "
            f"{sample.n_chunks} chunks of {sample.chunk_size}, {sample.n_replicates} replicate populations; a "
            "parameter two models share takes the same values in both, design by design), "
            f"seed {sample.seed}, {study.n_levels} levels per structure, models {', '.join(study.friction_models)}. "
            f"Acceptance: L-inf(f) <= {acceptance.frequency_tolerance_hz} Hz and L-inf(zeta) <= "
            f"{acceptance.damping_tolerance}. Linear damping cases: {json_text(explored['damping_cases'])}, made "
            f"each design's zeta_0 by the rule \"{explored['damping_rule']}\" (docs/design.md section 7).", "",
            heading(depth + 2, "Designs not converged (flagged, never dropped)"), "",
            *flag_table(designs, study.friction_models, [s["name"] for s in explored["structures"]])]


def surrogacy_lines(path: Path, depth: int) -> list[str]:
    """Paper Table 5's layout of one friction model from its surrogacy table (``study.surrogacy``'s CSV,
    ``surrogacy_markdown``), the model's heading at ``depth``; a line saying so where the table is absent."""
    if not path.exists():
        return [f"_{path.name} not written (step skipped?)_"]
    return surrogacy_markdown(pd.read_csv(path), depth=depth).strip().splitlines()


def model_lines(analysis: Path, model: str, depth: int, base: Path) -> list[str]:
    """One friction model's surrogacy table and figures (SC against the bounds, Pareto fronts, representative
    designs' responses) from the ``analysis`` folder, linked relative to ``base``; the model's heading below the
    study's at ``depth``."""
    return ["", heading(depth + 1, model), "", heading(depth + 2, "Surrogacy (paper Eq. 29, Table 5)"), "",
            *surrogacy_lines(analysis / f"surrogacy_{model}.csv", depth + 2), "",
            image_line(analysis / f"surrogacy_bounds_{model}.png", "SC against the acceptance bounds", base), "",
            heading(depth + 2, "Pareto fronts (paper Fig. 6)"), "", image_line(analysis / f"pareto_{model}.png",
                                                                               "fronts", base), "",
            heading(depth + 2, "Representative front designs (paper Figs. 9-11)"), "",
            image_line(analysis / f"responses_{model}.png", "responses", base)]


def analysis_text(path: Path) -> list[str]:
    """A finding the analysis wrote as Markdown text (the ANOVA beside Table 6, the prestress comparison)."""
    return path.read_text().strip().splitlines()


def findings_lines(analysis: Path, depth: int, base: Path) -> list[str]:
    """The ANOVA beside Table 6 and the prestress comparison (Fig. 12), where the analysis wrote them, linked
    relative to ``base``; headings below the study's at ``depth``."""
    lines = []
    if (analysis / "anova.md").exists():
        lines += ["", heading(depth + 1, "ANOVA (paper Table 6)"), "", *analysis_text(analysis / "anova.md")]
    if (analysis / "prestress.md").exists():
        lines += ["", heading(depth + 1, "Prestress and the SBRB (paper Fig. 12)"), "",
                  *analysis_text(analysis / "prestress.md"), "", image_line(analysis / "prestress.png", "prestress",
                                                                            base)]
    return lines


def study_lines(folder: Path, parameters: dict, explored: dict, depth: int, base: Path,
                reading=unchecked) -> list[str]:
    """Every section of the study in ``folder`` below its heading at ``depth`` (module docstring), from its resolved
    configuration ``parameters`` and its exploration's manifest ``explored``, figures linked relative to ``base``.
    reading(path, what): a context in which the record ``path`` (a ``what``) is read, naming it where it is
    damaged (``report.records.read_as``); by default none."""
    with reading(folder / "designs" / "exploration.json", "exploration manifest"):
        lines = structures_lines(explored["structures"], folder / "measurements", depth)
        lines += ["", *sample_lines(parameters, explored, folder / "designs", depth)]
    analysis = folder / "analysis"
    for model in parameters["study"].friction_models:
        with reading(analysis / f"surrogacy_{model}.csv", "surrogacy table"):
            lines += model_lines(analysis, model, depth, base)
    return lines + findings_lines(analysis, depth, base)


def write_report(paths, parameters: dict) -> Path:
    """Write the study's ``<out>/report.md`` (``paths``: ``study.workflow.Paths``), its figures linked from there."""
    lines = [heading(1, f"Surrogacy study: {parameters['study'].dataset}"), "",
             *study_lines(paths.out, parameters, manifest(paths.designs), 1, paths.out)]
    destination = paths.out / "report.md"
    with atomic_path(destination) as temporary:
        temporary.write_text("\n".join(lines) + "\n")
    return destination
