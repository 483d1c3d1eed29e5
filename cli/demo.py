"""The demo: every stage end to end, each one run as the user runs it (``surrogacy <stage> ...`` in a process of
its own), in the order the data flows, with the measured-data stages skipped, each with one line saying why, where
their data is absent.

Order. The ASB study needs nothing of ours but the installed tool (its superelements are ABAQUS's), while the
geometry, FE and reduction stages compute on one core: it runs beside them (its progress in
``results/study-asb.log``) and compiles the QSMA kernel into numba's cache for the beams' study as well. Its
calibration (``surrogacy fit``, which also derives acceptance bounds from the data) then runs beside the beams'
study and the discrepancy loops, and the report waits for it. The surrogacy confidence at those bounds
(``surrogacy confidence --bounds``, each model: step ``confidence-asb``) is one step away, not in the demo, as are
the beams' calibration and confidence (``fit-beams``, ``confidence-beams``). A failed stage stops the demo with its
exit status; Ctrl-C stops every stage still running (each exits 130, finished results kept).
"""

from __future__ import annotations

import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from experiment.backbone_files import freevib_stem
from reduction.superelement import ASB_CONFIGURATIONS
from report.studies import calibration_folder, study_folder
from study.datasets import DATASETS, dataset

STEPS = ("study-asb", "beams", "fe", "rom", "freevib", "fit-asb", "study-beams", "discrepancy", "discrepancy-modal-asb",
         "fit-beams", "confidence-asb", "confidence-beams", "report")
DEMO_STEPS = tuple(step for step in STEPS if step not in ("discrepancy-modal-asb", "fit-beams", "confidence-asb",
                                                          "confidence-beams"))
"""The steps ``make demo`` runs: all but the one-mode loop on the six ASB backbones (about 3 minutes more), the
beams' calibration (about 3 minutes) and the surrogacy confidence at each dataset's bounds from the data (about 1
minute per friction model)."""
FETCH = "make data, or surrogacy data fetch, downloads it"
"""How to get the public measured data a skipped step needs (``pipeline.public_data``)."""
BESIDE = {"study-asb": "fit-asb", "fit-asb": "report"}
"""Steps run in the background -> the step that waits for them: the ASB study beside beams, fe and rom (which
compute on one core), its calibration beside the beams' study and the discrepancy loops."""


@dataclass(frozen=True)
class DemoOptions:
    """What the demo reads and how big its studies are.

    data: folder with the ASB's measured backbones and reduced models (asb-backbones/, asb-reduced-models/).
    reference: a folder of the user's own paper tables for the studies (None: the paper's, in
    ``pipeline.published``). ringdown: a measured ring-down file, mode_hz its mode's frequency guess (Hz). designs, chunk: designs per friction model and per chunk of the studies. scheduler: a
    dask.distributed address or "local" (None: in the study's process). run_log: the run log every stage appends
    to (``surrogacy --run-log``). build, results: the stages' output folders.
    """

    data: Path
    reference: Path | None
    ringdown: Path
    mode_hz: float
    designs: int = 100_000
    chunk: int = 500
    scheduler: str | None = None
    run_log: Path | None = None
    build: Path = Path("build")
    results: Path = Path("results")


@dataclass(frozen=True)
class Step:
    """One run of a stage: its name, the ``surrogacy`` arguments of each run (several for the discrepancy loops),
    or the reason it is skipped."""

    name: str
    runs: tuple[tuple[str, ...], ...] = ()
    skipped: str | None = None


def study_options(options: DemoOptions) -> tuple[str, ...]:
    """The options both studies share: the user's paper tables where given, stale chunks recomputed, the sample's
    size."""
    scheduler = ("--scheduler", options.scheduler) if options.scheduler else ()
    reference = ("--reference", str(options.reference)) if options.reference is not None else ()
    return (*reference, "--restart-stale", "--set", f"sample.n_designs={options.designs}",
            "--set", f"sample.chunk_size={options.chunk}", *scheduler)


def plan(options: DemoOptions) -> list[Step]:
    """The demo's steps (``STEPS``), each with its runs or the reason it is skipped (its data absent, with the
    command that fetches it)."""
    build, results = options.build, options.results
    backbones = options.data / "asb-backbones"
    no_backbones = f"{backbones} not found ({FETCH})"
    steps = [Step("study-asb", (("study", "--out", str(results / "study-asb"), "--data", str(options.data),
                                 "--set", "study.dataset=asb", *study_options(options)),))
             if backbones.is_dir() else Step("study-asb", skipped=no_backbones),
             Step("beams", (("beams", "--out", str(build / "beams")),)),
             Step("fe", (("fe", "--beams", str(build / "beams"), "--out", str(build / "fe")),)),
             Step("rom", (("rom", "--beams", str(build / "beams"), "--fe", str(build / "fe"), "--out",
                           str(build / "rom")),))]
    if options.ringdown.is_file():
        steps.append(Step("freevib", (("freevib", str(options.ringdown), "--mode-hz", f"{options.mode_hz:g}",
                                       "--per-channel", "--provenance", "measured",  # the demo's ring-down is
                                       "--out", str(results / "freevib")),)))  # measured; its file does not say
    else:
        steps.append(Step("freevib", skipped=f"{options.ringdown} not found ({FETCH})"))
    steps.append(fit_step(results, "asb", None if backbones.is_dir() else no_backbones))
    steps.append(Step("study-beams", (("study", "--out", str(results / "study-beams"), "--rom", str(build / "rom"),
                                       *study_options(options)),)))
    loops = []
    if options.ringdown.is_file():  # the backbone freevib made of it
        backbone = results / "freevib" / f"{freevib_stem(options.ringdown, options.mode_hz)}_backbone.csv"
        loops.append(("discrepancy", str(backbone), "--out", str(results / "discrepancy" / "chen2022")))
    ran = {step.name for step in steps if not step.skipped}  # a study's step is named as its folder
    loops += [("discrepancy", "--study", str(study_folder(results, chosen)), "--structure", structure, "--out",
               str(results / "discrepancy" / f"study-{structure.replace(' ', '_')}"))
              for chosen in DATASETS.values() if study_folder(results, chosen).name in ran
              for structure in chosen.structures]
    steps.append(Step("discrepancy", tuple(loops)) if loops else Step("discrepancy", skipped="no measurement found"))
    asb_files = [backbones / f"ASB_{c}_20Nm_BB.mat" for c in ASB_CONFIGURATIONS]
    steps.append(Step("discrepancy-modal-asb", tuple(
        ("discrepancy", str(path), "--out", str(results / "discrepancy" / path.name.split("_20Nm")[0]))
        for path in asb_files if path.is_file())) if any(path.is_file() for path in asb_files)
        else Step("discrepancy-modal-asb", skipped=f"{backbones} holds no ASB backbone ({FETCH})"))
    steps.append(fit_step(results, "beams"))
    steps += [confidence_step(results, "asb", None if backbones.is_dir() else no_backbones),
              confidence_step(results, "beams")]
    steps.append(Step("report", (("report", "--build", str(build), "--results", str(results), "--out",
                                  str(results / "report.md")),)))
    return steps


def fit_step(results: Path, name: str, skipped: str | None = None) -> Step:
    """``fit-<name>``: the calibration of dataset ``name``'s study (``surrogacy fit``), with its bounds from the data;
    skipped for the reason given, if one is."""
    study, fit = study_folder(results, dataset(name)), calibration_folder(results, dataset(name))
    return (Step(fit.name, skipped=skipped) if skipped else
            Step(fit.name, (("fit", "--study", str(study), "--out", str(fit)),)))


def confidence_step(results: Path, name: str, skipped: str | None = None) -> Step:
    """``confidence-<name>``: each default model's surrogacy confidence on dataset ``name`` at the bounds
    ``fit-<name>`` derived; skipped for the reason given, if one is."""
    study, fit = study_folder(results, dataset(name)), calibration_folder(results, dataset(name))
    return (Step(f"confidence-{name}", skipped=skipped) if skipped else Step(f"confidence-{name}", tuple(
        ("confidence", "--study", str(study), "--model", model, "--bounds",
         str(fit / "bounds.csv"), "--out", str(fit / f"confidence_{model}.csv"))
        for model in dataset(name).default_models)))


def command(run: tuple[str, ...], run_log: Path | None) -> list[str]:
    """The command line of one run: this interpreter's ``surrogacy`` console script, the run log first."""
    log = ["--run-log", str(run_log)] if run_log is not None else []
    return [sys.executable, "-m", "cli.console", *log, *run]


def run_steps(steps: list[Step], options: DemoOptions) -> None:
    """Run the steps in order, ``BESIDE`` ones in the background until the step named there (or the end).
    The runs log to ``options.run_log``; a background run writes its output to ``<options.results>/<step>.log``.
    Raises ``subprocess.CalledProcessError`` with the exit status of the first run that fails; every run still
    going is stopped (SIGTERM) first."""
    background: list[tuple[str, subprocess.Popen, Path]] = []
    try:
        for step in steps:
            due = [entry for entry in background if BESIDE[entry[0]] == step.name]
            background = [entry for entry in background if entry not in due]
            wait_for(due)
            if step.skipped:
                print(f"{step.name}: {step.skipped}, skipped", flush=True)
                continue
            if step.name in BESIDE:
                log = options.results / f"{step.name}.log"
                log.parent.mkdir(parents=True, exist_ok=True)
                print(f"{step.name}: running beside the next steps; its progress: {log}", flush=True)
                with open(log, "w") as stream:
                    background.append((step.name, subprocess.Popen(
                        command(step.runs[0], options.run_log), stdout=stream, stderr=subprocess.STDOUT), log))
                continue
            for run in step.runs:
                print("surrogacy " + shlex.join(run), flush=True)
                subprocess.run(command(run, options.run_log), check=True)
        wait_for(background)
    finally:
        for _, process, _ in background:
            if process.poll() is None:
                process.terminate()
                process.wait()


def wait_for(background: list) -> None:
    """Wait for the background runs; the last lines of a failed one's log, then CalledProcessError."""
    while background:
        name, process, log = background.pop(0)
        status = process.wait()
        lines = log.read_text(errors="replace").splitlines()
        if status != 0:
            print("\n".join(lines[-5:]), file=sys.stderr)
            raise subprocess.CalledProcessError(status, f"{name} (its log: {log})")
        print(f"{name}: {lines[-1] if lines else 'done'}", flush=True)
