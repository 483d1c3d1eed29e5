"""The study report: one Markdown file with the figures, regenerated from the analysis folder (paper Figs. 6,
9-12, Tables 5-6), stating the provenance of every measurement and the designs that did not converge."""

from __future__ import annotations

import csv
from pathlib import Path

from pipeline.files import atomic_path, json_text
from study.analysis import reason_counts
from study.exploration import manifest


def _section(path: Path) -> str:
    return path.read_text().strip() if path.exists() else f"_{path.name} not written (step skipped?)_"


def flag_table(designs: Path, models, names) -> str:
    """Markdown table of designs not converged, per model and structure, by reason (most frequent first),
    counted chunk by chunk (``study.analysis.reason_counts``)."""
    lines = ["| model | structure | designs | not converged | reasons |", "|---|---|---|---|---|"]
    for model in models:
        n_designs, reasons = reason_counts(designs, model, names)
        for name in names:
            ranked = sorted(reasons[name].items(), key=lambda item: -item[1])
            counts = "; ".join(f"{reason}: {count}" for reason, count in ranked)
            lines.append(f"| {model} | {name} | {n_designs} | {sum(reasons[name].values())} | {counts or '-'} |")
    return "\n".join(lines)


def write_report(paths, parameters: dict) -> Path:
    """Write <out>/report.md."""
    explored = manifest(paths.designs)
    study, sample = parameters["study"], parameters["sample"]
    names = [s["name"] for s in explored["structures"]]
    virtual = any(s["provenance"] == "virtual" for s in explored["structures"])
    lines = [f"# Surrogacy study: {study.dataset}", ""]
    if virtual:
        lines += ["**The measurements of this study are VIRTUAL**: simulated ring-downs of one reference joint "
                  "(see measurements/<beam>_experiment.json), processed like measured data. They are not the "
                  "paper's measured curves, which are not public.", ""]
    lines += ["## Structures and target modes", "", "| structure | provenance | target mode | source |",
              "|---|---|---|---|"]
    lines += [f"| {s['name']} | {s['provenance']} | {s['mode_choice']} | {s['source']} |"
              for s in explored["structures"]]
    low_amplitude = paths.measurements / "low_amplitude.csv"
    if low_amplitude.exists():
        lines += ["", "### Low-amplitude frequencies of the virtual experiments against paper Table 1", "",
                  "| beam | virtual (Hz) | Table 1 (Hz) | difference (%) |", "|---|---|---|---|"]
        with open(low_amplitude, newline="") as stream:
            lines += [f"| {row['beam']} | {float(row['virtual_hz']):.2f} | {float(row['table1_hz']):.2f} | "
                      f"{float(row['difference_percent']):+.2f} |" for row in csv.DictReader(stream)]
    lines += ["", "## Sample", "",
              f"{sample.n_designs} designs per friction model (replicated Latin hypercube over paper Table 3, "
              f"{sample.n_chunks} chunks of {sample.chunk_size}, {sample.n_replicates} replicate populations; a "
              "parameter two models share takes the same values in both, design by design), "
              f"seed {sample.seed}, {study.n_levels} levels per structure, models {', '.join(study.friction_models)}."
              f" Acceptance: L-inf(f) <= {parameters['acceptance'].frequency_tolerance_hz} Hz and L-inf(zeta) <= "
              f"{parameters['acceptance'].damping_tolerance}. Linear damping cases: "
              f"{json_text(explored['damping_cases'])}, made each design's zeta_0 by the rule "
              f"\"{explored['damping_rule']}\" (docs/design.md section 7).", "", "### Designs not converged (flagged, never dropped)",
              "", flag_table(paths.designs, study.friction_models, names)]
    analysis = paths.analysis
    for model in study.friction_models:
        lines += ["", f"## {model}", "", "### Surrogacy (paper Eq. 29, Table 5)", "",
                  _section(analysis / f"surrogacy_{model}.md"), "",
                  f"![SC against the acceptance bounds](analysis/surrogacy_bounds_{model}.png)", "",
                  "### Pareto fronts (paper Fig. 6)", "", f"![fronts](analysis/pareto_{model}.png)", "",
                  "### Representative front designs (paper Figs. 9-11)", "",
                  f"![responses](analysis/responses_{model}.png)"]
    if (analysis / "anova.md").exists():
        lines += ["", "## ANOVA (paper Table 6)", "", _section(analysis / "anova.md")]
    if (analysis / "prestress.md").exists():
        lines += ["", "## Prestress and the SBRB (paper Fig. 12)", "", _section(analysis / "prestress.md"), "",
                  "![prestress](analysis/prestress.png)"]
    destination = paths.out / "report.md"
    with atomic_path(destination) as temporary:
        temporary.write_text("\n".join(lines) + "\n")
    return destination

