"""The pipeline's report: one Markdown file (``results/report.md``) with every stage's figures and tables, read
back from the files the stages wrote, so it states only what a run produced. Each section is a function of the
stages' records (sidecars, JSON records, CSV tables, figures); the datasets are those of the registry
(``study.datasets``).

Sections, in the order the data flows: the three meshes (geometry), contact pressure under the bolt preload and
the tied first bending (fem), the superelements (reduction), the backbones to fit (paper Fig. 3: the beams'
virtual experiments, the ASB's measured backbones, the Chen 2022 measured ring-down), each dataset's surrogacy
study (:mod:`report.studies`: Pareto fronts, Figs. 6, 9-12, Tables 5-6 beside the paper's), the calibration
(fitted designs against the study's fronts), the discrepancy loop's before/after table, the provenance (commit,
versions, seeds, configuration, per-stage wall times and peak memory from the ``surrogacy --run-log`` file), and
QSMA against EPMC on the studies' representative designs (:mod:`report.epmc`, where ``make epmc`` ran). A stage
whose files are missing is named as not run, never filled in; a file absent where its stage ran (a figure, a
calibration's table beside its records, a discrepancy loop's record) is named as missing where it belongs, never
linked or dropped; a damaged record (cut short, a field missing) is refused naming it, before any file is written.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from discrepancy.files import verdict_summary
from experiment.measured_files import read_mode_backbone
from geometry.parameters import BEAM_NAMES
from nonlinear.friction_models import MODEL_NAMES
from pipeline.files import atomic_path, check_output_file, check_output_folder, json_float, json_text
from report.epmc import epmc_section
from report.markdown import measured_stage_not_run
from report.records import read_as, read_record
from report.studies import calibration_folder, study_folder, study_section
from study.datasets import DATASETS
from study.figures import plt, save
from study.report import image_line, low_amplitude_markdown, relative_link
from virtual_experiment.hammer_test import experiment_record_path

RINGDOWN_DATA = "the measured Chen 2022 ring-down"
"""The public measured data freevib reads."""
RINGDOWN_TITLE = "ring-down (surrogacy freevib)"
"""The title of freevib's backbones in the backbone figure."""
BACKBONE_FIGURE = "report_backbones.png"
"""The backbone figure (paper Fig. 3), drawn beside the report."""


@dataclass(frozen=True)
class Folders:
    """Where the stages wrote: ``build`` (beams/, fe/, rom/), ``results`` (freevib/, study-*/, discrepancy/) and
    the run log of ``surrogacy --run-log`` (None: no timings)."""

    build: Path
    results: Path
    run_log: Path | None = None


def stage_table(folder: Path, columns: list[str], cells) -> list[str]:
    """A Markdown table with a row per beam from its sidecar ``<folder>/<beam>.json``: ``cells(sidecar)`` gives the
    row's cells after the beam's name; a beam without a sidecar is said not run."""
    lines = ["| beam | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for beam in BEAM_NAMES:
        sidecar = read_record(folder / f"{beam}.json")
        with read_as(folder / f"{beam}.json", "stage sidecar"):
            row = cells(sidecar) if sidecar is not None else ["not run"] + [""] * (len(columns) - 1)
        lines.append(f"| {beam} | " + " | ".join(row) + " |")
    return lines


def mesh_cells(sidecar: dict) -> list[str]:
    """Nodes, masses on the mesh and from the drawing (kg), interface area on the mesh and from the drawing
    (mm^2, the lower half's patches)."""
    measured, analytic = sidecar["measured"], sidecar["analytic"]
    area = sum(value for name, value in measured["patch_area_m2"].items() if name.startswith("lower_"))
    return [str(sidecar["nodes"]), f"{measured['mass_kg']:.4f}", f"{analytic['mass_kg']:.4f}",
            f"{1e6 * area:.1f} / {1e6 * sum(analytic['patch_area_m2']):.1f}"]


def geometry_section(build: Path, out: Path) -> list[str]:
    """Table of the meshes and their renders."""
    table = stage_table(build / "beams", ["nodes", "mass on the mesh (kg)", "mass from the drawing (kg)",
                                          "interface area, mesh / drawing (mm^2)"], mesh_cells)
    return (["## 1. Geometry: the three Brake-Reuss beams", "", *table, ""]
            + [image_line(build / "beams" / f"{beam}.png", f"{beam} mesh", out,
                          (build / "beams" / f"{beam}.json").exists()) for beam in BEAM_NAMES])


def fe_section(build: Path, out: Path) -> list[str]:
    """Tied first bending (unstressed and prestressed), peak contact pressure, and the renders."""
    table = stage_table(build / "fe", ["tied first bending (Hz)", "prestressed (Hz)", "peak contact pressure (MPa)"],
                        lambda sidecar: [f"{sidecar['first_bending_hz']['tied']:.2f}",
                                         f"{sidecar['first_bending_hz']['tied_prestressed']:.2f}",
                                         f"{1e-6 * sidecar['contact_pressure_range_pa'][1]:.1f}"])
    lines = ["## 2. Finite elements: bolt preload, frictionless contact, stress stiffness, modes", "", *table, ""]
    for beam in BEAM_NAMES:
        ran = (build / "fe" / f"{beam}.json").exists()
        lines += [image_line(build / "fe" / f"{beam}_contact_pressure.png", f"{beam} contact pressure", out, ran),
                  image_line(build / "fe" / f"{beam}_first_bending.png", f"{beam} tied first bending", out, ran)]
    return lines


def reduction_section(build: Path, out: Path) -> list[str]:
    """Superelements: mass and the stuck-joint frequencies (the joint's stiffest state)."""
    table = stage_table(build / "rom", ["mass (kg)", "stuck-joint frequencies (Hz)"],
                        lambda sidecar: [f"{sidecar['mass_kg']:.4f}",
                                         ", ".join(f"{f:.2f}" for f in sidecar["stuck_joint_frequencies_hz"])])
    return (["## 3. Superelements (Hurty/Craig-Bampton, 60 + 26 DOFs)", "", *table, ""]
            + [image_line(build / "rom" / f"{beam}_first_bending.png", f"{beam} superelement first bending", out,
                      (build / "rom" / f"{beam}.json").exists()) for beam in BEAM_NAMES])


def plot_backbones(destination: Path, groups: dict) -> None:
    """Paper Fig. 3: natural frequency relative to its low-amplitude value, and damping ratio, against amplitude;
    one column per group of backbones (title -> list of ModeBackbone), each curve labelled with its provenance."""
    figure, axes = plt.subplots(2, len(groups), figsize=(4.6 * len(groups), 6.4), squeeze=False)
    for column, (title, backbones) in enumerate(groups.items()):
        for mode in backbones:
            points = mode.backbone.with_data()
            label = f"{mode.structure} ({mode.provenance})"
            axes[0, column].semilogx(points.amplitude, points.natural_frequency_hz / mode.low_amplitude_frequency_hz,
                                     "o-", ms=3, label=label)
            axes[1, column].semilogx(points.amplitude, points.damping_ratio, "o-", ms=3, label=label)
        unit = backbones[0].amplitude_unit
        axes[0, column].set(title=title, ylabel="f / f(lowest amplitude) (-)")
        axes[1, column].set(xlabel=f"amplitude ({unit})", ylabel="damping ratio (-)")
        axes[0, column].legend(fontsize=7)
    figure.suptitle("Backbones of the structures' first bending modes (paper Fig. 3)")
    figure.tight_layout()
    save(figure, destination)


def backbone_groups(results: Path) -> dict:
    """The backbones the studies fit and freevib's, by the title of their group in the backbone figure (the
    groups that hold any)."""
    sources = {chosen.backbone_title: sorted((study_folder(results, chosen) / "measurements").glob("*.csv"))
               for chosen in DATASETS.values()}
    sources[RINGDOWN_TITLE] = sorted((results / "freevib").glob("*_backbone.csv"))
    groups = {title: [read_mode_backbone(path) for path in files if path.name != "low_amplitude.csv"]
              for title, files in sources.items()}
    return {title: backbones for title, backbones in groups.items() if backbones}


def backbone_section(results: Path, out: Path, groups: dict) -> list[str]:
    """The backbones the studies fit (virtual beams, measured ASB; ``groups`` of :func:`backbone_groups`) in one
    figure (``report_backbones.png`` beside the report, drawn by :func:`write_pipeline_report`), the Chen
    ring-down's FreeVib backbone, and the virtual experiments' low-amplitude frequencies against paper Table 1."""
    lines = ["## 4. Backbones to fit (paper Fig. 3)", ""]
    if groups:
        lines += ["The beams' backbones are **virtual**: simulated hammer ring-downs of one reference joint in "
                  "each beam's model, processed as measured data (paper's measured curves are not public). The "
                  "ASB's are measured.", "", f"![backbones]({relative_link(out / BACKBONE_FIGURE, out)})", ""]
    for chosen in DATASETS.values():
        low_amplitude = study_folder(results, chosen) / "measurements" / "low_amplitude.csv"
        if low_amplitude.exists():
            lines += ["Lowest-amplitude frequency of the virtual experiments against paper Table 1:", "",
                      *low_amplitude_markdown(low_amplitude), ""]
    runs = sorted({path.stem for pattern in ("*.png", "*.json") for path in (results / "freevib").glob(pattern)})
    lines += ["Measured ring-down (Chen 2022 BRB hammer test), both FreeVib estimators:", ""]
    lines += ([image_line(results / "freevib" / f"{stem}.png", stem, out) for stem in runs]
              or [measured_stage_not_run("freevib", RINGDOWN_DATA)])
    for mode in groups.get(RINGDOWN_TITLE, []):
        settings = mode.settings
        lines += ["", f"{mode.structure}: the Hilbert backbone that the discrepancy loop reads (section 8), "
                      "estimated "
                      f"once by surrogacy freevib around {settings.get('mode_hz', float('nan')):g} Hz"
                      f"{', each channel a record' if settings.get('per_channel') else ''}; its settings are recorded "
                      "in the backbone file."]
    return lines


def calibrated_models(folder: Path) -> list[str]:
    """The friction models a calibration folder (``surrogacy fit --out``) holds anything of: a folder of
    calibration records (``<model>/<structure>.json``, a model of the registry), a front (``front_<model>.csv``)
    or a figure (``fits_<model>.png``)."""
    models = {path.parent.name for path in folder.glob("*/*.json") if path.parent.name in MODEL_NAMES}
    models |= {path.stem.removeprefix("front_") for path in folder.glob("front_*.csv")}
    return sorted(models | {path.stem.removeprefix("fits_") for path in folder.glob("fits_*.png")})


def calibration_section(results: Path, out: Path) -> list[str]:
    """Each calibration's table (``surrogacy fit``: results/fit-<dataset>/calibration.md), its figures of the
    best compromise against the measurement (one per model it holds) and its confidence matrices; a table, a
    figure or a confidence CSV absent where the calibration's other files are is named."""
    lines = ["## 7. Calibration: joint designs fitted to the measured backbones", ""]
    folders = sorted(path for path in results.glob("fit-*") if path.is_dir())
    for folder in folders:
        table, models = folder / "calibration.md", calibrated_models(folder)
        name = folder.name.removeprefix("fit-")
        if table.exists():
            body = table.read_text().splitlines()[1:]  # without its own title
            lines += [f"Calibration of {name} ({relative_link(table, out)}):", *body, ""]
        else:
            records = [path for model in models for path in sorted((folder / model).glob("*.json"))]
            lines += [f"_Calibration of {name}: {table} absent; "
                      + (f"its {len(records)} calibration record(s) are there ({', '.join(models)}): the "
                         "calibration ran, its table was deleted or not written (rerun `surrogacy fit`, which "
                         "writes it from the records)_" if records else
                         f"no calibration record in {folder} either (calibration not run)_"), ""]
        lines += [image_line(folder / f"fits_{model}.png", f"fits_{model}", out) for model in models]
        for model in sorted({path.name.removeprefix("confidence_").split(".")[0]
                             for path in folder.glob("confidence_*") if path.suffix in (".csv", ".png")}):
            path = folder / f"confidence_{model}.csv"
            lines += (confidence_matrix(path, out) if path.exists() else
                      [f"_Surrogacy confidence of {model}: {path} absent beside its figure (rerun `surrogacy "
                       "confidence`)_", ""])
            lines += [image_line(path.with_suffix(".png"), f"confidence_{model}", out), ""]
    lines += [] if folders else ["_calibration not run_", ""]
    return lines + [measured_stage_not_run(f"calibration of {chosen.name} ({calibration_folder(results, chosen).name})",
                                           chosen.measured_data)
                    for chosen in DATASETS.values()
                    if chosen.measured_data is not None and not calibration_folder(results, chosen).is_dir()]


CONFIDENCE_NAMES = ("model", "surrogate", "real")
CONFIDENCE_BOUNDS = ("surrogate_frequency_tolerance_hz", "surrogate_damping_tolerance", "sample_accepted_surrogate")
CONFIDENCE_ESTIMATES = ("confidence", "lower", "upper", "sample_confidence")
"""The columns of a ``surrogacy confidence`` CSV the report reads: names (never empty), numbers every row has, and
estimates (empty where a region was not reached or the sample accepted nothing)."""


def confidence_table(path: Path) -> pd.DataFrame:
    """A ``surrogacy confidence`` CSV (docs/formats.md) with its numbers as floats. A file pandas cannot parse, a
    column missing, no row, an empty name or a bound that is not a finite number (a line cut short leaves its last
    cells empty) raises a ValueError naming the file, the line (the header is line 1) and the column."""
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError) as error:  # pandas' parser errors and a UnicodeDecodeError are ValueErrors
        raise ValueError(f"{path}: not a readable surrogacy confidence CSV ({error})") from None
    missing = [column for column in (*CONFIDENCE_NAMES, *CONFIDENCE_BOUNDS, *CONFIDENCE_ESTIMATES)
               if column not in table]
    if missing or table.empty:
        raise ValueError(f"{path}: " + (f"column {missing[0]!r} missing" if missing else "no row")
                         + "; expected the table surrogacy confidence writes")
    for column in CONFIDENCE_NAMES + CONFIDENCE_BOUNDS:
        values = table[column] if column in CONFIDENCE_NAMES else pd.to_numeric(table[column], errors="coerce")
        bad = np.flatnonzero(values == "") if column in CONFIDENCE_NAMES else np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(f"{path}: line {bad[0] + 2}, column {column!r}: {table[column][bad[0]]!r}; expected "
                             + ("a name" if column in CONFIDENCE_NAMES else "a finite number")
                             + " (a line cut short?)")
    numbers = list(CONFIDENCE_BOUNDS + CONFIDENCE_ESTIMATES)
    table[numbers] = table[numbers].apply(pd.to_numeric, errors="coerce")
    return table


def confidence_matrix(path: Path, out: Path) -> list[str]:
    """A ``surrogacy confidence`` CSV as a matrix: rows the surrogate I (with its bounds), columns the real
    structure J, each cell SC_IJ [95 % interval] by subset simulation, and the study's own sample's count at the
    same bounds where it accepted any design."""
    table = confidence_table(path)
    names = list(dict.fromkeys(table["real"]))
    lines = [f"Surrogacy confidence of {table['model'][0]} at the bounds from the data ({relative_link(path, out)}; "
             "subset simulation, in brackets its 95 % interval, \"not reached\" where its runs stalled short of I's "
             "region at every number of designs per level tried; after the slash the study's sample at the same "
             "bounds, - where it accepted nothing):", "",
             "| surrogate I (f bound Hz, zeta bound) | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for surrogate, rows in table.groupby("surrogate", sort=False):
        first = rows.iloc[0]
        cells = [(f"{row.confidence:.2f} [{row.lower:.2f}, {row.upper:.2f}]" if np.isfinite(row.confidence)
                  else "not reached") + " / " + (f"{row.sample_confidence:.2f}" if row.sample_accepted_surrogate > 0
                                                 else "-") for row in rows.itertuples()]
        lines.append(f"| {surrogate} ({first.surrogate_frequency_tolerance_hz:.3g}, "
                     f"{first.surrogate_damping_tolerance:.2g}) | " + " | ".join(cells) + " |")
    return lines + [""]


def discrepancy_section(results: Path, out: Path) -> list[str]:
    """Per measurement: the effects the discrepancy loop found (or "unexplained"), the errors of the reference
    model (before) and of the final model (after), and beside them the findings of the ring-down's signal checks
    (``experiment.signal_checks``: what the backbone hides)."""
    runs = sorted(path for path in (results / "discrepancy").glob("*") if path.is_dir())
    lines = ["## 8. Discrepancy loop: what the one-mode joint model lacks", ""]
    if not runs:
        return lines + ["_discrepancy not run_"]
    lines += ["Reference model: the one-mode joint model (a linear mode and a Jenkins element) on a measurement "
              "file, or the Jenkins joint refitted on the structure's superelement from the study's designs "
              "(`study-<structure>`; every model the loop tries there is refitted). An effect is accepted only "
              "with its parameters determined and neither L-infinity error worse than the reference's beyond "
              "the measurement's uncertainty; of the models tried within a BIC of 10 of the best that hold none of "
              "the others, the answer is the one with the lowest BIC, and the others as good are listed. Errors are "
              "of the reference (before) and of the final model (after). Signal findings: what the checks "
              "of the ring-down's signals saw beside the backbone (a finding outside the effect library makes the "
              "verdict unexplained; \"not checked\" for a backbone without its ring-down).", "",
              "| measurement | provenance | reference model | effects found | signal findings | verdict | "
              "L-inf f (Hz) before -> after | RMS f (Hz) | L-inf zeta | RMS zeta |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for folder in runs:
        path = folder / "discrepancy.json"
        verdict = read_record(path)
        if verdict is None:
            present = sorted(child.name for child in folder.iterdir() if not child.name.startswith("."))
            lines.append(f"| {folder.name} | {path.name} absent from {folder} "
                         f"({'beside ' + ', '.join(present) if present else 'no result file there'}): rerun "
                         "`surrogacy discrepancy` | | | | | | | | |")
            continue
        document = path.with_suffix(".md")
        name = (f"[{folder.name}]({relative_link(document, out)})" if document.exists() else
                f"{folder.name} ({document} absent)")
        with read_as(path, "discrepancy record"):
            lines.append(verdict_row(verdict, name))
    lines.append("")
    lines += [image_line(folder / "discrepancy.png", f"{folder.name} before and after", out) for folder in runs
              if any((folder / name).exists() for name in ("discrepancy.json", "discrepancy.png"))]
    return lines


def verdict_row(verdict: dict, name: str) -> str:
    """A row of section 8's table for the discrepancy record ``verdict`` (``discrepancy.json``) named ``name``."""
    before, after = verdict["steps"][0]["errors"], verdict["steps"][-1]["errors"]
    changes = [f"{json_float(before[key]):.3g} -> {json_float(after[key]):.3g}"
               for key in ("frequency_linf_hz", "frequency_rms_hz", "damping_linf", "damping_rms")]
    if "joint_law" not in verdict:
        return (f"| {name} | written before the loop named the joint law apart: rerun `surrogacy discrepancy` "
                "| | | | | | | | |")
    found = verdict_summary(verdict["joint_law"], verdict["added"], verdict["alternatives"])
    findings = verdict.get("findings", [])
    seen = "; ".join(f"{entry['name']}: {entry['summary']}" for entry in findings) or (
        "none" if verdict.get("signal_checks") else "not checked")
    outside = [entry["name"] for entry in findings if entry["outside_library"]]
    answer = (f"unexplained ({', '.join(outside)})" if outside else
              "residual unexplained" if verdict["unexplained"] else "explained to the noise") + (
        "; the drift within each hit taken out of the backbone before the fit" if verdict.get("drift_correction")
        else "")
    reference = (f"superelement, {verdict['steps'][0]['parameters']['design']}" if "study" in verdict
                 else "one-mode joint")
    return (f"| {name} | {verdict['provenance']} | {reference} | {found} | {seen} | {answer} | "
            + " | ".join(changes) + " |")


def git_commit() -> str:
    """The commit of the code that wrote the report, marked where the checkout has uncommitted changes
    ('unknown' outside a git checkout)."""
    def git(*words):
        return subprocess.run(["git", *words], capture_output=True, text=True, check=True,
                              cwd=Path(__file__).parent).stdout.strip()

    try:
        commit = git("rev-parse", "HEAD")
        return commit + (" with uncommitted changes" if git("status", "--porcelain", "--untracked-files=no") else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


RUN_RECORD = {"command": list, "finished": str, "wall_s": (int, float), "peak_memory_mb": (int, float),
              "status": int}
"""The fields of a run log's line (``cli.console.log_run``) and their JSON types."""


def run_record(line: str) -> dict | str:
    """One line of a run log as its record, or what is wrong with it (a line cut short, not one JSON object, a
    field of :data:`RUN_RECORD` missing or of another type)."""
    try:
        record = json.loads(line)
    except json.JSONDecodeError as error:
        return f"not one JSON object ({error}; a line cut short?)"
    if not isinstance(record, dict):
        return "not one JSON object"
    wrong = [key for key, kind in RUN_RECORD.items()
             if not isinstance(record.get(key), kind) or isinstance(record.get(key), bool)]
    return f"field(s) {', '.join(wrong)} missing or not of their type" if wrong else record


def timings_table(run_log: Path | None) -> list[str]:
    """Per-stage wall time and peak memory: the last logged run of each command line; a damaged line of the log
    is named (the log, the line, what is wrong) and left out."""
    if run_log is None or not run_log.exists():
        return ["_no run log (run the stages with `surrogacy --run-log FILE`, as `make demo` does)_"]
    runs, damaged = {}, []
    for number, line in enumerate(run_log.read_text(errors="replace").splitlines(), start=1):
        record = run_record(line) if line.strip() else "empty"
        if isinstance(record, str):
            damaged.append(f"_{run_log}, line {number}: {record}; left out of this table_")
        else:
            runs[" ".join(map(str, record["command"]))] = record
    lines = ["| command | finished | wall time (s) | peak memory (MB) | exit status |", "|---|---|---|---|---|"]
    lines += [f"| `{command}` | {record['finished']} | {record['wall_s']:.1f} | {record['peak_memory_mb']:.0f} | "
              f"{record['status']} |" for command, record in runs.items()]
    return lines + ([""] + damaged if damaged else [])


def provenance_section(folders: Folders) -> list[str]:
    """Commit, package versions, seeds and configurations of every stage, and the per-stage timings."""
    lines = ["## 9. Provenance", "", f"Code: commit {git_commit()}.", "", "| stage | versions | seed |",
             "|---|---|---|"]
    for stage, sidecar in (("geometry", folders.build / "beams" / "BRB.json"), ("fem", folders.build / "fe" / "BRB.json"),
                           ("reduction", folders.build / "rom" / "BRB.json")):
        values = read_record(sidecar)
        if values is not None:
            with read_as(sidecar, "stage sidecar"):
                lines.append(f"| {stage} | {json_text(values['versions'])} | - |")
    for chosen in DATASETS.values():
        for structure in chosen.structures:
            path = experiment_record_path(study_folder(folders.results, chosen) / "measurements", structure)
            experiment = read_record(path)
            if experiment is not None:
                with read_as(path, "virtual experiment record"):
                    lines.append(f"| virtual experiment {structure} | {json_text(experiment['versions'])} | "
                                 f"{experiment['seed']} |")
    configurations = []
    for chosen in DATASETS.values():
        path = study_folder(folders.results, chosen) / "study.json"
        study = read_record(path)
        if study is not None:
            with read_as(path, "study record"):
                lines.append(f"| study ({chosen.name}) | {json_text(study['versions'])} | {study['seed']} |")
                configurations += [f"Study configuration ({chosen.name}):", "", "```json",
                                   json_text(study["configuration"], indent=1, sort_keys=True), "```", ""]
    return lines + [""] + configurations + ["### Per-stage wall time and peak memory", "",
                                            *timings_table(folders.run_log)]


def write_pipeline_report(folders: Folders, destination: Path) -> Path:
    """Write the report (module docstring) to ``destination`` (Markdown) and its backbone figure beside it. A
    destination that cannot be written (a folder, or in a folder that cannot be one) is refused before any work
    (``pipeline.files.OutputFolderError``); a damaged record is refused naming it before any file is written."""
    check_output_file(destination)
    check_output_folder(Path(destination).parent)
    out, groups = Path(destination).parent, backbone_groups(folders.results)
    lines = ["# Surrogate system hypothesis for joint mechanics: pipeline report", "",
             "The beams' \"measurements\" in this report are **VIRTUAL** (simulated ring-downs of a reference joint, "
             "labelled virtual wherever they appear); the ASB backbones and the Chen 2022 ring-down are measured.",
             "", "Contents: 1 geometry, 2 finite elements, 3 superelements, 4 backbones, 5-6 surrogacy studies "
             "(Table 5, Figs. 6, 9-12, Table 6), 7 calibration, 8 discrepancy loop, 9 provenance, 10 QSMA against the "
             "nonlinear mode by harmonic balance (EPMC).", ""]
    lines += geometry_section(folders.build, out) + [""]
    lines += fe_section(folders.build, out) + [""]
    lines += reduction_section(folders.build, out) + [""]
    lines += backbone_section(folders.results, out, groups) + [""]
    for number, chosen in enumerate(DATASETS.values(), start=5):
        lines += study_section(chosen, folders.results, out, number) + [""]
    lines += calibration_section(folders.results, out) + [""]
    lines += discrepancy_section(folders.results, out) + [""]
    lines += provenance_section(folders) + [""]
    lines += epmc_section(folders.results, out, 10)
    if groups:
        plot_backbones(out / BACKBONE_FIGURE, groups)
    with atomic_path(destination) as temporary:
        temporary.write_text("\n".join(lines) + "\n")
    return Path(destination)
