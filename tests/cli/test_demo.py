"""The demo's plan and its runner: which stage runs with which arguments, what is skipped and why, the ASB study
beside the first stages, and a failed stage's exit status as the demo's."""

import subprocess
import sys
import time

import pytest

from locations import REPOSITORY
from cli import demo
from cli.console import main as surrogacy


def options(tmp_path, **changes) -> demo.DemoOptions:
    values = dict(data=tmp_path / "data", reference=None, ringdown=tmp_path / "hits.mat",
                  mode_hz=80.5, designs=2000, chunk=500, build=tmp_path / "build", results=tmp_path / "results")
    return demo.DemoOptions(**(values | changes))


def by_name(steps) -> dict:
    return {step.name: step for step in steps}


def test_without_data_the_beams_run_and_each_measured_step_says_how_to_fetch_its_data(tmp_path):
    steps = by_name(demo.plan(options(tmp_path)))
    assert list(steps) == list(demo.STEPS) and demo.STEPS[0] in demo.BESIDE  # started first, beside the others
    fetch = "(make data, or surrogacy data fetch, downloads it)"
    assert steps["fit-asb"].skipped == f"{tmp_path / 'data' / 'asb-backbones'} not found {fetch}"
    assert [name for name, step in steps.items() if not step.skipped] == [
        "beams", "fe", "rom", "study-beams", "discrepancy", "fit-beams", "confidence-beams", "report"]
    assert steps["freevib"].skipped == f"{tmp_path / 'hits.mat'} not found {fetch}"
    assert steps["study-asb"].skipped == f"{tmp_path / 'data' / 'asb-backbones'} not found {fetch}"
    assert steps["discrepancy-modal-asb"].skipped.endswith(fetch)
    assert "--reference" not in steps["study-beams"].runs[0]  # the paper's tables, in the project
    assert [run[4] for run in steps["discrepancy"].runs] == ["BRB", "LBRB", "SBRB"]
    assert steps["rom"].runs == (("rom", "--beams", str(tmp_path / "build" / "beams"), "--fe",
                                  str(tmp_path / "build" / "fe"), "--out", str(tmp_path / "build" / "rom")),)


def test_with_data_every_measured_data_step_runs_with_the_study_s_options(tmp_path):
    (tmp_path / "data" / "asb-backbones").mkdir(parents=True)
    (tmp_path / "data" / "asb-backbones" / "ASB_C1_20Nm_BB.mat").write_bytes(b"")
    (tmp_path / "hits.mat").write_bytes(b"")
    steps = by_name(demo.plan(options(tmp_path, scheduler="local", reference=tmp_path / "reference")))
    assert not any(step.skipped for step in steps.values())
    shared = ("--reference", str(tmp_path / "reference"), "--restart-stale", "--set", "sample.n_designs=2000",
              "--set", "sample.chunk_size=500", "--scheduler", "local")
    assert steps["study-asb"].runs == (("study", "--out", str(tmp_path / "results" / "study-asb"), "--data",
                                        str(tmp_path / "data"), "--set", "study.dataset=asb", *shared),)
    assert steps["study-beams"].runs[0][-len(shared):] == shared
    fit, study = tmp_path / "results" / "fit-asb", str(tmp_path / "results" / "study-asb")
    assert steps["fit-asb"].runs == (("fit", "--study", study, "--out", str(fit)),)
    assert steps["confidence-asb"].runs == tuple(
        ("confidence", "--study", study, "--model", model, "--bounds", str(fit / "bounds.csv"), "--out",
         str(fit / f"confidence_{model}.csv")) for model in ("jenkins", "iwan4", "iwan5", "iwan4_core"))
    beams_fit, beams_study = tmp_path / "results" / "fit-beams", str(tmp_path / "results" / "study-beams")
    assert steps["fit-beams"].runs == (("fit", "--study", beams_study, "--out", str(beams_fit)),)
    assert steps["confidence-beams"].runs == tuple(
        ("confidence", "--study", beams_study, "--model", model, "--bounds", str(beams_fit / "bounds.csv"), "--out",
         str(beams_fit / f"confidence_{model}.csv")) for model in ("jenkins", "iwan4", "iwan5", "iwan4_stuck"))
    assert not {"confidence-asb", "fit-beams", "confidence-beams"} & set(demo.DEMO_STEPS)
    loops = steps["discrepancy"].runs
    assert steps["freevib"].runs == (("freevib", str(tmp_path / "hits.mat"), "--mode-hz", "80.5", "--per-channel",
                                      "--provenance", "measured", "--out", str(tmp_path / "results" / "freevib")),)
    assert loops[0] == ("discrepancy", str(tmp_path / "results" / "freevib" / "hits_mode_80.5Hz_backbone.csv"),
                        "--out", str(tmp_path / "results" / "discrepancy" / "chen2022"))  # the ring-down processed once
    assert [run[4] for run in loops[1:]] == ["BRB", "LBRB", "SBRB", "ASB C1", "ASB C2", "ASB C3", "ASB C4",
                                             "ASB C4a", "ASB CD1"]
    assert [run[1] for run in steps["discrepancy-modal-asb"].runs] == [
        str(tmp_path / "data" / "asb-backbones" / "ASB_C1_20Nm_BB.mat")]


def fake_commands(monkeypatch, scripts: dict):
    """Each run replaced by a short Python script (keyed by the run's first argument after the stage name)."""
    monkeypatch.setattr(demo, "command", lambda run, run_log: [sys.executable, "-c", scripts[run[0]]])


def test_the_background_steps_run_beside_the_others_and_are_waited_for(tmp_path, monkeypatch, capsys):
    """The ASB study runs beside beams and is finished before its calibration starts; the calibration runs beside
    the beams' study and is finished before the report."""
    started, studied, fitted = (tmp_path / name for name in ("asb-started", "asb-done", "fit-done"))
    fake_commands(monkeypatch, {
        "study-asb": f"import time, pathlib; pathlib.Path({str(started)!r}).touch(); time.sleep(0.5); "
                     f"pathlib.Path({str(studied)!r}).touch(); print('done')",
        "beams": f"import pathlib, time\nfor _ in range(100):\n    if pathlib.Path({str(started)!r}).exists(): break\n"
                 "    time.sleep(0.05)\nelse: raise SystemExit(4)",
        "fit-asb": f"import time, pathlib; assert pathlib.Path({str(studied)!r}).exists(); time.sleep(0.5); "
                   f"pathlib.Path({str(fitted)!r}).touch(); print('fitted')",
        "study-beams": f"import pathlib; assert not pathlib.Path({str(fitted)!r}).exists()",  # the fit is beside it
        "report": f"import pathlib; assert pathlib.Path({str(fitted)!r}).exists()"})
    steps = [demo.Step("study-asb", (("study-asb",),)), demo.Step("beams", (("beams",),)),
             demo.Step("freevib", skipped="no ring-down"), demo.Step("fit-asb", (("fit-asb",),)),
             demo.Step("study-beams", (("study-beams",),)), demo.Step("report", (("report",),))]
    demo.run_steps(steps, options(tmp_path))
    out = capsys.readouterr().out
    assert "freevib: no ring-down, skipped" in out and "study-asb: done" in out and "fit-asb: fitted" in out
    assert (tmp_path / "results" / "study-asb.log").read_text() == "done\n"


def test_a_failed_stage_stops_the_demo_and_the_background_study(tmp_path, monkeypatch):
    started = tmp_path / "started"
    fake_commands(monkeypatch, {"study-asb": f"import time, pathlib; pathlib.Path({str(started)!r}).touch(); "
                                             "time.sleep(60)",
                                "beams": "raise SystemExit(3)"})
    steps = [demo.Step("study-asb", (("study-asb",),)), demo.Step("beams", (("beams",),))]
    start = time.monotonic()
    with pytest.raises(subprocess.CalledProcessError) as failure:
        demo.run_steps(steps, options(tmp_path))
    assert failure.value.returncode == 3
    assert time.monotonic() - start < 30  # the background study (60 s) was stopped, not waited for


def test_the_command_runs_the_chosen_steps_and_skips_what_has_no_data(tmp_path, capsys):
    missing = tmp_path / "missing.mat"
    assert surrogacy(["demo", "--steps", "freevib", "--ringdown", str(missing)]) == 0
    assert capsys.readouterr().out == (f"freevib: {missing} not found (make data, or surrogacy data fetch, "
                                       "downloads it), skipped\n")


def test_make_demo_is_one_surrogacy_demo_command():
    result = subprocess.run(["make", "-n", "-C", str(REPOSITORY), "demo"],
                            capture_output=True, text=True, timeout=60)
    commands = [line for line in result.stdout.splitlines() if "surrogacy" in line]
    assert result.returncode == 0 and len(commands) == 1 and " demo --data " in commands[0], result.stdout
