"""The report's study sections (``report.studies``) are assembled from the study's records: the same text as the
study's own report one heading level down with its figures linked from the pipeline report, whether or not the
study's report.md is there; the studies are those of the dataset registry."""

from __future__ import annotations

import shutil

import pytest

from cli.console import main as surrogacy
from locations import ASB_MODELS
from report.markdown import relative_link
from report.studies import study_folder, study_section
from study.datasets import DATASETS, dataset

ASB_BACKBONES = ASB_MODELS.parent / "asb-backbones"


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


def one_level_down(report_text: str, study: str, out) -> list[str]:
    """The study's own report as the pipeline report shows it (written here, by hand, from its text): headings one
    level down, the title numbered, figure links relative to ``out``."""
    lines = []
    for line in report_text.splitlines():
        if line.startswith("#"):
            line = "#" + line
        if line.startswith("!["):
            caption, target = line[2:-1].split("](")
            line = f"![{caption}]({relative_link(study / target, out)})"
        lines.append(line)
    return [lines[0].replace("## Surrogacy study:", "## 6. Surrogacy study:"), *lines[1:]]


def test_study_section_is_the_study_report_one_level_down(asb_study, tmp_path):
    """The section from the records reads as the study's report.md, a level down, with links from a report in
    another folder; every link is to a figure that exists."""
    study = study_folder(asb_study, dataset("asb"))
    out = tmp_path / "elsewhere"
    out.mkdir()
    section = study_section(dataset("asb"), asb_study, out, 6)
    assert section == one_level_down((study / "report.md").read_text(), study, out)
    links = [line.split("](")[1][:-1] for line in section if line.startswith("![")]
    assert links and all((out / link).exists() for link in links)


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
