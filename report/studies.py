"""A dataset's surrogacy study in the pipeline report, assembled from the study's records (``study.report``'s
sections one heading level down, its figures linked from the pipeline report): its configuration
(``study.json``), its exploration's manifest (``designs/exploration.json``), the analysis' tables, texts and
figures. A damaged record is named (``report.records.read_as``).

Studies are found through the dataset registry (``study.datasets``): a dataset's study is in
``<results>/study-<dataset>``, its calibration in ``<results>/fit-<dataset>``.
"""

from __future__ import annotations

from pathlib import Path

from pipeline.config import resolve
from report.markdown import measured_stage_not_run
from report.records import read_as, read_record
from study.datasets import Dataset
from study.exploration import manifest
from study.parameters import defaults
from study.report import heading, study_lines

STUDY_RECORDS = ("study.json", "designs/exploration.json", "analysis")
"""What a study folder holds once its analysis ran, in the order its steps write them."""
DEPTH = 2
"""The level of a study's heading in the pipeline report."""


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


def study_section(chosen: Dataset, results: Path, out: Path, number: int) -> list[str]:
    """Section ``number`` of the report: the study of dataset ``chosen`` from its records (module docstring), its
    figures linked relative to ``out``; where its analysis is absent, a line saying what ran. A damaged record
    raises a ValueError naming it."""
    folder = study_folder(results, chosen)
    lines = [heading(DEPTH, f"{number}. Surrogacy study: {chosen.name}"), ""]
    if not all((folder / name).exists() for name in STUDY_RECORDS):
        return lines + [study_not_reported(folder, chosen.measured_data)]
    record = read_record(folder / "study.json")
    with read_as(folder / "study.json", "study record"):
        parameters = resolve(defaults(), record["configuration"], source=str(folder / "study.json"))
    return lines + study_lines(folder, parameters, manifest(folder / "designs"), DEPTH, out, read_as)
