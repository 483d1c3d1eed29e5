"""The study's sections (``study.report``) at a heading depth, their figures linked from a folder: the study's own
report.md and the pipeline report's study section (``report.studies``), assembled from the study's records whether
or not the study's report.md is there; the studies are those of the dataset registry."""

from __future__ import annotations

import shutil

import pytest

from cli.console import main as surrogacy
from locations import ASB_BACKBONES, ASB_MODELS
from report.studies import study_folder, study_section
from study.datasets import DATASETS, dataset
from study.exploration import manifest
from study.report import study_lines, write_report
from study.workflow import read_study


@pytest.fixture(scope="module")
def asb_study(tmp_path_factory):
    """A small ASB study of one friction model, every step run (its report.md written)."""
    if not ASB_BACKBONES.is_dir():
        pytest.skip(f"ASB measured backbones not available at {ASB_BACKBONES} (shared data folder absent)")
    results = tmp_path_factory.mktemp("studies") / "results"
    assert surrogacy(["study", "--out", str(study_folder(results, dataset("asb"))), "--data", str(ASB_MODELS.parent),
                      "--set", "study.dataset=asb", "--set", "sample.n_designs=1000", "--set", "sample.chunk_size=500",
                      "--set", 'study.models=["jenkins"]', "--set", "pareto.generations=2",
                      "--set", "pareto.population=8"]) == 0
    return results


def headings(lines: list[str]) -> list[tuple[int, str]]:
    """Each Markdown heading's level and text."""
    return [(len(line) - len(line.lstrip("#")), line.lstrip("# ")) for line in lines if line.startswith("#")]


def test_study_sections_sit_below_the_depth_given_and_link_their_figures_from_the_base(asb_study, tmp_path):
    """The same sections at two depths differ only in their headings' levels, each below the study's; with the
    links taken from another folder, every figure link leads from there to a figure that exists."""
    folder = study_folder(asb_study, dataset("asb"))
    parameters = read_study(folder).parameters
    explored = manifest(folder / "designs")
    out = tmp_path / "elsewhere"
    out.mkdir()
    shallow, deep = (study_lines(folder, parameters, explored, depth, out) for depth in (1, 3))
    assert [text for _, text in headings(shallow)] == [text for _, text in headings(deep)]
    assert all(level > 1 for level, _ in headings(shallow)) and all(level > 3 for level, _ in headings(deep))
    assert [level + 2 for level, _ in headings(shallow)] == [level for level, _ in headings(deep)]
    links = [line.split("](")[1][:-1] for line in deep if line.startswith("![")]
    assert len(links) == 3 and all((out / link).is_file() for link in links)


def test_the_study_report_names_a_figure_deleted_before_it_was_written(asb_study, tmp_path):
    """The study's own report.md links its figures from its folder, and names one that is absent, never a broken
    link."""
    copy = tmp_path / "study"
    shutil.copytree(study_folder(asb_study, dataset("asb")), copy)
    (copy / "analysis" / "pareto_jenkins.png").unlink()
    study = read_study(copy)
    text = write_report(study.paths, study.parameters).read_text()
    assert "![responses](analysis/responses_jenkins.png)" in text
    assert "](analysis/pareto_jenkins.png)" not in text and "_fronts: figure missing:" in text


def test_study_section_reads_no_study_report(asb_study, tmp_path):
    """Without the study's report.md (and with its analysis Markdown of the surrogacy table gone, whose numbers are
    in the CSV), the section is the same: it is made from the records, not from another report's text."""
    copy = tmp_path / "results"
    shutil.copytree(asb_study, copy)
    study = study_folder(copy, dataset("asb"))
    (study / "report.md").unlink()
    (study / "analysis" / "surrogacy_jenkins.md").unlink()
    assert study_section(dataset("asb"), copy, copy, 6) == study_section(dataset("asb"), asb_study, asb_study, 6)


def test_a_figure_deleted_from_the_study_is_named_missing(asb_study, tmp_path):
    copy = tmp_path / "results"
    shutil.copytree(asb_study, copy)
    figure = study_folder(copy, dataset("asb")) / "analysis" / "pareto_jenkins.png"
    figure.unlink()
    section = study_section(dataset("asb"), copy, copy, 6)
    assert f"_fronts: figure missing: {figure} is absent although its stage ran (deleted, or not drawn: rerun the " \
           "stage to draw it)_" in section


@pytest.mark.parametrize("name", sorted(DATASETS))
def test_every_dataset_of_the_registry_has_its_study_section(name, tmp_path):
    """Each registered dataset's study is looked for in results/study-<dataset> and named not run where absent."""
    section = study_section(dataset(name), tmp_path, tmp_path, 5)
    assert section[0] == f"## 5. Surrogacy study: {name}" and "not run" in section[-1]
