"""A dataset's surrogacy study in the pipeline report, assembled from the study's records: its configuration
(``study.json``), its exploration's manifest (``designs/exploration.json``: structures, target modes, damping
cases), the virtual experiments' lowest-amplitude frequencies, the designs not converged (counted from the chunks),
each friction model's surrogacy table (``analysis/surrogacy_<model>.csv``, paper Table 5 beside it) and figures
(paper Figs. 6, 9-11), the ANOVA (Table 6) and the prestress comparison (Fig. 12) as the analysis wrote them.

Studies are found through the dataset registry (``study.datasets``): a dataset's study is in
``<results>/study-<dataset>``, its calibration in ``<results>/fit-<dataset>``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from pipeline.config import resolve
from pipeline.files import json_text
from report.markdown import image_line, low_amplitude_markdown, measured_stage_not_run
from report.records import read_as, read_record
from study.datasets import ASB, BEAMS, Dataset
from study.exploration import manifest
from study.parameters import defaults
from study.report import flag_table
from study.surrogacy import CONFIDENCE_LEVEL, surrogacy_cell

MEASURED_DATA = {ASB: "the measured ASB backbones and reduced models"}
"""The public measured data a dataset's study reads, where it reads any (the report names it where the study did
not run)."""
BACKBONE_TITLES = {BEAMS: "beams: VIRTUAL experiments", ASB: "ASB: measured"}
"""A dataset's title in the report's backbone figure (its name where it has none here)."""
STUDY_RECORDS = ("study.json", "designs/exploration.json", "analysis")
"""What a study folder holds once its analysis ran, in the order its steps write them."""


def study_folder(results: Path, chosen: Dataset) -> Path:
    """Where the pipeline writes the study of dataset ``chosen``."""
    return Path(results) / f"study-{chosen.name}"


def calibration_folder(results: Path, chosen: Dataset) -> Path:
    """Where the pipeline writes the calibration (``surrogacy fit``) of dataset ``chosen``'s study."""
    return Path(results) / f"fit-{chosen.name}"


def study_not_reported(folder: Path, data: str | None = None) -> str:
    """What the report says of a study folder without its analysis: not run (with the measured data it reads and
    the command that fetches it, where ``data`` names it), or run (some of its files are there) but not to its
    analysis, naming the first record absent."""
    absent = [folder / name for name in STUDY_RECORDS if not (folder / name).exists()]
    if len(absent) == len(STUDY_RECORDS):
        return "_study not run_" if data is None else measured_stage_not_run("study", data)
    return (f"_{absent[0]} absent: the study ran ({folder} holds its files) but not to its analysis (rerun "
            f"`surrogacy study --out {folder}` with the study's options)_")


def structures_table(structures: list[dict]) -> list[str]:
    """The study's structures (the manifest's records): provenance, the target mode chosen and the source of the
    measurement."""
    return ["| structure | provenance | target mode | source |", "|---|---|---|---|",
            *(f"| {s['name']} | {s['provenance']} | {s['mode_choice']} | {s['source']} |" for s in structures)]


def sample_paragraph(parameters: dict, explored: dict) -> str:
    """The sample (designs, chunks, replicates, seed), levels, models, acceptance bounds (Hz, -) and the linear
    damping cases with the rule that makes them each design's zeta_0."""
    study, sample, acceptance = parameters["study"], parameters["sample"], parameters["acceptance"]
    return (f"{sample.n_designs} designs per friction model (replicated Latin hypercube over paper Table 3, "
            f"{sample.n_chunks} chunks of {sample.chunk_size}, {sample.n_replicates} replicate populations; a "
            "parameter two models share takes the same values in both, design by design), "
            f"seed {sample.seed}, {study.n_levels} levels per structure, models {', '.join(study.friction_models)}. "
            f"Acceptance: L-inf(f) <= {acceptance.frequency_tolerance_hz} Hz and L-inf(zeta) <= "
            f"{acceptance.damping_tolerance}. Linear damping cases: {json_text(explored['damping_cases'])}, made "
            f"each design's zeta_0 by the rule \"{explored['damping_rule']}\" (docs/design.md section 7).")


def surrogacy_matrix(path: Path, model: str) -> list[str]:
    """Paper Table 5's layout of one friction model from its surrogacy table (``study.surrogacy``'s CSV): SC_IJ
    with its binomial interval and counts, rows surrogate S, columns real R, the paper's value beside it."""
    if not path.exists():
        return [f"_{path.name} not written (step skipped?)_"]
    with read_as(path, "surrogacy table"):
        table = pd.read_csv(path)
        structures = list(dict.fromkeys(table["surrogate"]))
        cells = {(row.surrogate, row.real): surrogacy_cell(row) for row in table.itertuples()}
        rows = [f"| {surrogate} | " + " | ".join(cells[surrogate, real] for real in structures) + " |"
                for surrogate in structures]
    return [f"Surrogacy confidence SC_IJ = n_IJ / n_I (paper Eq. 29) with its {100 * CONFIDENCE_LEVEL:g} % "
            "binomial confidence interval and (n_IJ/n_I); rows surrogate S, columns real R.", "", f"#### {model}",
            "", "| S \\ R | " + " | ".join(structures) + " |", "|---" * (len(structures) + 1) + "|", *rows]


def analysis_text(path: Path) -> list[str]:
    """A finding the analysis wrote as Markdown text (the ANOVA beside Table 6, the prestress comparison)."""
    return path.read_text().strip().splitlines()


def model_lines(analysis: Path, model: str, out: Path) -> list[str]:
    """One friction model's surrogacy table and figures (SC against the bounds, Pareto fronts, representative
    designs' responses), linked relative to the report's folder ``out``."""
    return ["", f"### {model}", "", "#### Surrogacy (paper Eq. 29, Table 5)", "",
            *surrogacy_matrix(analysis / f"surrogacy_{model}.csv", model), "",
            image_line(analysis / f"surrogacy_bounds_{model}.png", "SC against the acceptance bounds", out), "",
            "#### Pareto fronts (paper Fig. 6)", "", image_line(analysis / f"pareto_{model}.png", "fronts", out), "",
            "#### Representative front designs (paper Figs. 9-11)", "",
            image_line(analysis / f"responses_{model}.png", "responses", out)]


def study_section(chosen: Dataset, results: Path, out: Path, number: int) -> list[str]:
    """Section ``number`` of the report: the study of dataset ``chosen`` from its records (module docstring), its
    figures linked relative to ``out``; where its analysis is absent, a line saying what ran. A damaged record
    raises a ValueError naming it."""
    folder = study_folder(results, chosen)
    lines = [f"## {number}. Surrogacy study: {chosen.name}", ""]
    if not all((folder / name).exists() for name in STUDY_RECORDS):
        return lines + [study_not_reported(folder, MEASURED_DATA.get(chosen))]
    record = read_record(folder / "study.json")
    with read_as(folder / "study.json", "study record"):
        parameters = resolve(defaults(), record["configuration"], source=str(folder / "study.json"))
    explored = manifest(folder / "designs")
    with read_as(folder / "designs" / "exploration.json", "exploration manifest"):
        structures = explored["structures"]
        if any(s["provenance"] == "virtual" for s in structures):
            lines += ["**The measurements of this study are VIRTUAL**: simulated ring-downs of one reference joint "
                      "(see measurements/<beam>_experiment.json), processed like measured data. They are not the "
                      "paper's measured curves, which are not public.", ""]
        lines += ["### Structures and target modes", "", *structures_table(structures)]
        low_amplitude = folder / "measurements" / "low_amplitude.csv"
        if low_amplitude.exists():
            lines += ["", "#### Low-amplitude frequencies of the virtual experiments against paper Table 1", "",
                      *low_amplitude_markdown(low_amplitude)]
        lines += ["", "### Sample", "", sample_paragraph(parameters, explored), "",
                  "#### Designs not converged (flagged, never dropped)", "",
                  *flag_table(folder / "designs", parameters["study"].friction_models,
                              [s["name"] for s in structures]).splitlines()]
    analysis = folder / "analysis"
    for model in parameters["study"].friction_models:
        lines += model_lines(analysis, model, out)
    if (analysis / "anova.md").exists():
        lines += ["", "### ANOVA (paper Table 6)", "", *analysis_text(analysis / "anova.md")]
    if (analysis / "prestress.md").exists():
        lines += ["", "### Prestress and the SBRB (paper Fig. 12)", "", *analysis_text(analysis / "prestress.md"),
                  "", image_line(analysis / "prestress.png", "prestress", out)]
    return lines
