"""The pipeline's report (``surrogacy report``) and the run log it takes its timings from: every number it shows
is the one the stage wrote, every image it links exists, a stage not run is named as such, and each logged run
carries its real exit status."""

from __future__ import annotations

import json
import re

import pytest

from geometry.parameters import BEAM_NAMES
from cli.console import main as surrogacy
from discrepancy.files import verdict_summary
from discrepancy.virtual_data import write_undeclared_ringdown
from report.document import Folders, write_pipeline_report
from locations import ASB_BACKBONES, ASB_MODELS

ASB_C1 = ASB_BACKBONES / "ASB_C1_20Nm_BB.mat"


def test_run_log_records_each_run_with_its_status(tmp_path):
    """Every stage runs with the log option (freevib once wrote all its options, the log's path among them, into
    its JSON and failed on it)."""
    log, ring_down = tmp_path / "runs.jsonl", tmp_path / "ring.csv"
    write_undeclared_ringdown(ring_down)
    assert surrogacy(["--run-log", str(log), "freevib", str(tmp_path / "missing.mat"), "--mode-hz", "80"]) == 2
    assert surrogacy(["--run-log", str(log), "freevib", str(ring_down), "--mode-hz", "169", "--out",
                      str(tmp_path / "freevib")]) == 0
    assert '"run_log"' not in (tmp_path / "freevib" / "ring_mode_169Hz.json").read_text()
    assert surrogacy(["--run-log", str(log), "report", "--build", str(tmp_path), "--results", str(tmp_path),
                      "--out", str(tmp_path / "report.md")]) == 0
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert [record["status"] for record in records] == [2, 0, 0]
    assert records[0]["command"][:2] == ["surrogacy", "freevib"]  # the stage's command line, not the log option
    assert all(record["wall_s"] >= 0 and record["peak_memory_mb"] > 10 for record in records)


def test_a_cut_run_log_keeps_the_next_run_whole_and_the_report_names_the_line(tmp_path):
    """A run log whose last line was cut short: the next run's record is a line of its own (it was glued to the
    cut one), and the report's timings name the log and the cut line and show the whole records."""
    log, build, results = tmp_path / "runs.jsonl", tmp_path / "build", tmp_path / "results"
    build.mkdir(), results.mkdir()
    report = ["report", "--build", str(build), "--results", str(results), "--out", str(tmp_path / "report.md")]
    assert surrogacy(["--run-log", str(log), *report]) == 0
    whole = log.read_text()
    log.write_text(whole + whole[:len(whole) // 2])
    assert surrogacy(["--run-log", str(log), *report]) == 0
    lines = log.read_text().splitlines()
    assert len(lines) == 3 and lines[1] == whole[:len(whole) // 2].strip()
    assert [json.loads(lines[index])["status"] for index in (0, 2)] == [0, 0]
    text = (tmp_path / "report.md").read_text()
    assert re.search(rf"_{re.escape(str(log))}, line 2: not one JSON object \(.+; a line cut short\?\); left out", text)
    first = json.loads(lines[0])
    assert f"| `{' '.join(first['command'])}` | {first['finished']} | {first['wall_s']:.1f} |" in text


def test_report_into_a_folder_is_refused_before_any_work(tmp_path, capsys):
    """``--out`` naming an existing folder: one line naming it, at once and writing nothing (it named the report's
    temporary file after the work)."""
    build, results, out = tmp_path / "build", tmp_path / "results", tmp_path / "report"
    for folder in (build, results, out):
        folder.mkdir()
    assert surrogacy(["report", "--build", str(build), "--results", str(results), "--out", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"surrogacy report: error: {out}: a folder; expected the name of a file to write (a new or "
                     "existing file)"]
    assert not any(out.iterdir())


@pytest.fixture(scope="module")
def pipeline_report(beam_roms, tmp_path_factory):
    """The report of the default beams' build and a small ASB study and one discrepancy loop, with a run log."""
    if not ASB_C1.exists():
        pytest.skip(f"ASB measured backbone not available at {ASB_C1} (shared data folder absent)")
    folder = tmp_path_factory.mktemp("report")
    log, results = folder / "runs.jsonl", folder / "results"
    assert surrogacy(["--run-log", str(log), "study", "--out", str(results / "study-asb"), "--data",
                      str(ASB_MODELS.parent), "--set", "study.dataset=asb", "--set", "sample.n_designs=2000",
                      "--set", "sample.chunk_size=1000", "--set", 'study.models=["jenkins"]',
                      "--set", "pareto.generations=3", "--set", "pareto.population=16"]) == 0
    assert surrogacy(["--run-log", str(log), "discrepancy", str(ASB_C1), "--out",
                      str(results / "discrepancy" / "ASB_C1")]) == 0
    assert surrogacy(["--run-log", str(log), "fit", "--study", str(results / "study-asb"), "--structures", "ASB C1",
                      "--max-generations", "5", "--out", str(results / "fit-asb")]) == 0
    assert surrogacy(["--run-log", str(log), "report", "--build", str(beam_roms.parent), "--results", str(results),
                      "--out", str(results / "report.md")]) == 0
    return results / "report.md", beam_roms.parent, results


def test_report_numbers_are_the_stages_own(pipeline_report):
    report, build, results = pipeline_report
    text = report.read_text()
    for beam in BEAM_NAMES:
        fe = json.loads((build / "fe" / f"{beam}.json").read_text())
        assert f"| {beam} | {fe['first_bending_hz']['tied']:.2f} |" in text
        rom = json.loads((build / "rom" / f"{beam}.json").read_text())
        assert f"| {beam} | {rom['mass_kg']:.4f} | {rom['stuck_joint_frequencies_hz'][0]:.2f}, " in text
    verdict = json.loads((results / "discrepancy" / "ASB_C1" / "discrepancy.json").read_text())
    before, after = verdict["steps"][0]["errors"], verdict["steps"][-1]["errors"]
    assert f"{before['frequency_linf_hz']:.3g} -> {after['frequency_linf_hz']:.3g}" in text
    assert verdict_summary(verdict["joint_law"], verdict["added"], verdict["alternatives"]) in text
    surrogacy_table = (results / "study-asb" / "analysis" / "surrogacy_jenkins.md").read_text().strip()
    assert surrogacy_table.splitlines()[-1] in text  # Table 5's layout with the paper's values, embedded
    calibration_table = (results / "fit-asb" / "calibration.md").read_text().strip()
    assert calibration_table.splitlines()[-1] in text and "| jenkins | ASB C1 |" in text  # the calibration's row
    study = json.loads((results / "study-asb" / "study.json").read_text())
    assert f"| study (asb) | {json.dumps(study['versions'])} | {study['seed']} |" in text


def test_report_shows_every_figure_the_stages_wrote_and_names_stages_not_run(pipeline_report):
    report, build, results = pipeline_report
    text = report.read_text()
    linked = {(report.parent / link).resolve() for link in re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)}
    assert all(path.exists() for path in linked)
    written = [*(build / stage / f"{beam}{suffix}" for stage, suffixes in
                 (("beams", [".png"]), ("fe", ["_contact_pressure.png", "_first_bending.png"]),
                  ("rom", ["_first_bending.png"])) for suffix in suffixes for beam in BEAM_NAMES),
               *results.rglob("*.png")]
    assert {path.resolve() for path in written if path.exists()} == linked
    assert ("_freevib not run: it reads the measured Chen 2022 ring-down; `make data` (`surrogacy data fetch`) "
            "fetches the data where it is absent_") in text  # this run had no ring-down stage: said, not filled in
    assert "calibration of asb (fit-asb) not run" not in text  # it ran
    assert "## 5. Surrogacy study: beams\n\n_study not run_" in text
    for section in ("## 1. Geometry", "## 2. Finite elements", "## 3. Superelements", "## 4. Backbones",
                    "## 6. Surrogacy study: asb", "## 7. Calibration", "## 8. Discrepancy loop", "## 9. Provenance"):
        assert section in text


def test_stages_without_their_measured_data_say_the_command_that_fetches_it(tmp_path):
    """A report of a run without the public measured data (a fresh clone's demo runs the beams only; here nothing
    ran): each stage that reads the data is named not run with the data and the command that fetches it; the beams'
    study, which needs none, is only named not run."""
    build, results = tmp_path / "build", tmp_path / "results"
    build.mkdir()
    results.mkdir()
    text = write_pipeline_report(Folders(build, results), results / "report.md").read_text()
    asb = "the measured ASB backbones and reduced models"
    fetch = "`make data` (`surrogacy data fetch`) fetches the data"
    assert f"_freevib not run: it reads the measured Chen 2022 ring-down; {fetch} where it is absent_" in text
    assert f"## 6. Surrogacy study: asb\n\n_study not run: it reads {asb}; {fetch} where it is absent_" in text
    assert f"_calibration of asb (fit-asb) not run: it reads {asb}; {fetch} where it is absent_" in text
    assert "## 5. Surrogacy study: beams\n\n_study not run_" in text


def test_report_timings_are_the_logged_runs(pipeline_report):
    report, _, results = pipeline_report
    text = report.read_text()
    records = [json.loads(line) for line in (results.parent / "runs.jsonl").read_text().splitlines()]
    for record in records[:2]:  # the study and the discrepancy loop (the report logs itself after writing)
        row = f"| `{' '.join(record['command'])}` | {record['finished']} | {record['wall_s']:.1f} |"
        assert row in text


def test_discrepancy_section_shows_the_signal_findings_beside_the_errors(tmp_path):
    """Section 8: a verdict with a finding outside the library reads "unexplained" with the finding named in the
    same row as the errors before and after, and a drift within each hit taken out of the backbone is said there;
    a backbone without its ring-down reads "not checked"."""
    from report.document import discrepancy_section

    errors = {"frequency_linf_hz": 0.5, "frequency_rms_hz": 0.2, "damping_linf": 1e-3, "damping_rms": 5e-4}
    second_mode = {"name": "second_mode", "outside_library": True, "summary": "a second mode at 174.6 Hz",
                   "evidence": {}}
    drift = {"natural_frequency_hz": {"rate_per_s": -0.08, "standard_error": 0.01, "largest_shift": 0.12}}
    for name, findings, checked in (("ring", [second_mode], ["second_mode", "drift"]), ("asb", [], [])):
        folder = tmp_path / "results" / "discrepancy" / name
        folder.mkdir(parents=True)
        (folder / "discrepancy.json").write_text(json.dumps({
            "provenance": "virtual", "effects": [], "unexplained": bool(findings), "findings": findings,
            "signal_checks": checked, "joint_law": [], "added": [], "alternatives": {},
            "drift_correction": drift if findings else {}, "steps": [{"errors": errors, "parameters": {}}]}))
        (folder / "discrepancy.md").write_text("Discrepancy loop\n")
    rows = {line.split("|")[1].strip(): line for line in discrepancy_section(tmp_path / "results", tmp_path)
            if line.startswith("| [")}
    ring, asb = (rows[f"[{name}](results/discrepancy/{name}/discrepancy.md)"] for name in ("ring", "asb"))
    assert ("| second_mode: a second mode at 174.6 Hz | unexplained (second_mode); the drift within each hit taken "
            "out of the backbone before the fit | 0.5 -> 0.5 |") in ring
    assert "| joint law macroslip; added outside the joint none | not checked | explained to the noise |" in asb


def test_report_on_a_partly_deleted_results_folder_names_what_is_missing(pipeline_report, tmp_path):
    """The results with a study figure, a calibration figure, calibration.md (its records kept), one loop's
    discrepancy.json and another's .md and .png deleted, and a build whose BRB mesh ran without its render and
    nothing else, and a study folder without its report: exit 0, no link to an absent file, each absent file named
    where it belongs, no loop dropped, neither the calibration nor that study called not run, the stages never run
    named so."""
    import shutil

    report, build, results = pipeline_report
    damaged, partial = tmp_path / "results", tmp_path / "build"
    shutil.copytree(results, damaged)
    shutil.copytree(damaged / "discrepancy" / "ASB_C1", damaged / "discrepancy" / "ASB_C1_again")
    (partial / "beams").mkdir(parents=True)
    shutil.copy(build / "beams" / "BRB.json", partial / "beams")
    (damaged / "study-beams").mkdir()
    shutil.copy(damaged / "study-asb" / "study.json", damaged / "study-beams")  # a study without its analysis
    deleted = [damaged / "study-asb" / "analysis" / "pareto_jenkins.png", damaged / "fit-asb" / "fits_jenkins.png",
               damaged / "fit-asb" / "calibration.md", damaged / "discrepancy" / "ASB_C1" / "discrepancy.json",
               damaged / "discrepancy" / "ASB_C1_again" / "discrepancy.md",
               damaged / "discrepancy" / "ASB_C1_again" / "discrepancy.png"]
    for path in deleted:
        path.unlink()
    out = damaged / "report.md"
    assert surrogacy(["report", "--build", str(partial), "--results", str(damaged), "--out", str(out)]) == 0
    text = out.read_text()
    linked = [(out.parent / link).resolve() for link in re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)]
    assert linked and all(path.exists() for path in linked)
    for path in (deleted[0], deleted[1], deleted[5], partial / "beams" / "BRB.png"):
        assert f"figure missing: {path} is absent although its stage ran" in text
    records = len(list((damaged / "fit-asb").glob("*/*.json")))
    assert f"{deleted[2]} absent; its {records} calibration record(s) are there (jenkins): the calibration ran" in text
    assert "_calibration not run_" not in text
    assert (f"| ASB_C1 | discrepancy.json absent from {deleted[3].parent} (beside discrepancy.md, "
            "discrepancy.png)") in text
    assert f"| ASB_C1_again ({deleted[4]} absent) | measured |" in text
    assert f"_LBRB mesh: {partial / 'beams' / 'LBRB.png'} not written (stage not run)_" in text
    assert (f"## 5. Surrogacy study: beams\n\n_{damaged / 'study-beams' / 'designs' / 'exploration.json'} absent: "
            f"the study ran ({damaged / 'study-beams'} holds its files) but not to its analysis") in text


@pytest.mark.parametrize("damage, message", [
    (lambda text: text[:len(text) // 2], "not one JSON object ("),
    (lambda text: json.dumps({key: value for key, value in json.loads(text).items() if key != "steps"}),
     "not a discrepancy record: field 'steps' missing"),
])
def test_a_damaged_discrepancy_record_is_refused_naming_it_and_changes_no_file(pipeline_report, tmp_path, capsys,
                                                                                damage, message):
    """A discrepancy.json cut in half, or without its steps: one line naming the file, exit 2, and the report
    and its backbone figure as the last run wrote them (a record is never trusted on its name alone)."""
    import shutil

    from stage_runs import digests

    report, build, results = pipeline_report
    damaged = tmp_path / "results"
    shutil.copytree(results, damaged)
    record = damaged / "discrepancy" / "ASB_C1" / "discrepancy.json"
    record.write_text(damage(record.read_text()))
    before = digests(damaged)
    assert surrogacy(["report", "--build", str(build), "--results", str(damaged), "--out",
                      str(damaged / "report.md")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith(f"surrogacy report: error: {record}: {message}") and len(error.splitlines()) == 1
    assert digests(damaged) == before


def test_a_confidence_table_cut_short_is_refused_naming_the_line(tmp_path):
    """The confidence CSV of a region not reached (the estimate's cells empty, as written) reads; cut inside its
    third row, it is refused naming the file, the line and the first empty cell; a file without a row, too."""
    from report.document import confidence_matrix, confidence_table
    from study.subset_simulation import subset_table, write_subset_csv

    path = tmp_path / "confidence_jenkins.csv"
    write_subset_csv(subset_table(None, "jenkins", ["ASB C1", "ASB C2", "ASB C3"], 0.3, 5e-4, surrogate=0,
                                  note="not reached"), path)
    assert "| ASB C1 (0.3, 0.0005) | not reached / - | not reached / - | not reached / - |" in confidence_matrix(
        path, tmp_path)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:3] + [lines[3][:len("jenkins,ASB C1,ASB C3")]]))
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: line 4, column "
                                         r"'surrogate_frequency_tolerance_hz': ''; expected a finite number"):
        confidence_table(path)
    path.write_text(lines[0] + "\n")
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: no row"):
        confidence_table(path)
