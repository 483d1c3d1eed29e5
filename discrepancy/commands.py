"""``surrogacy discrepancy``: what the model of a measured mode lacks, with the effects found, the evidence and the
errors before and after.

Two models:

``surrogacy discrepancy FILE``: a backbone CSV (a ring-down is processed into one by ``surrogacy freevib``) or an
ASB measured backbone (.mat with Q, W, Z), with the one-mode joint model (``discrepancy.loop``) for measurements with no
finite-element model behind them, at the nominal low-amplitude frequency and linear damping of the structure's
model (``--nominal-frequency-hz``, ``--nominal-damping``; default: the measurement's own values at its lowest
amplitude, so that only the amplitude dependence is questioned).

``surrogacy discrepancy --study FOLDER --structure NAME``: a structure of a surrogacy study (``surrogacy study``
output, analysed), with its superelement and the study's Pareto designs of each friction model as the reference
(``discrepancy.superelement_route``): what the study's best fit misses, and which effect explains it.

A backbone CSV written by ``surrogacy freevib`` carries the findings of the ring-down's signal checks (a second
mode, a drift over the hits, clipping, no pre-trigger, a truncated record); one outside the effect library makes the
verdict "unexplained" with the finding named, whatever the backbone's residual.

Writes to ``--out``: ``discrepancy.md`` (the findings of the signal checks, the effect found at each step, the
evidence: chi^2 per degree of freedom, BIC of every candidate, L-infinity and RMS errors of frequency and damping
before and after),
``discrepancy.png`` (measurement and the model before and after) and ``discrepancy.json`` (the same numbers and
the fitted parameters).
"""

from __future__ import annotations

import argparse
from functools import partial
from pathlib import Path

from discrepancy.files import write_verdict
from discrepancy.loop import discrepancy_loop, with_findings
from discrepancy.superelement_route import from_study, structure_discrepancy_loop
from experiment.measured_files import BACKBONE, known_formats, read_mode_backbone
from pipeline.files import stage_folder
from reduction.superelement import StructureError
from study.structures import N_LEVELS, measured_levels


def backbone_levels(measured, levels: int, path: Path):
    """The measured backbone binned to ``levels`` (``study.structures.measured_levels``); a backbone it refuses
    raises its error with the findings outside the library that the ring-down's signal checks saw, which may be
    why (a second mode's beating can drive a level's damping below zero)."""
    try:
        return measured_levels(measured, levels, str(path))
    except StructureError as error:
        outside = [f"{entry['name']}: {entry['summary']}" for entry in measured.findings.get("found", [])
                   if entry["outside_library"]]
        if not outside:
            raise
        raise StructureError(f"{error}; the ring-down's signal checks found what no backbone effect stands for: "
                             + "; ".join(outside)) from error


def run(arguments: argparse.Namespace) -> None:
    """Run the loop on one measured backbone (FILE, one-mode model) or on a study's structure (its superelement
    and the study's fits) and write its report."""
    if (arguments.file is None) == (arguments.study is None):
        raise ValueError("give either FILE (a measured backbone) or --study FOLDER --structure NAME")
    if arguments.study is not None:
        if arguments.structure is None:
            raise ValueError("--study needs --structure NAME (e.g. 'ASB C1' or 'LBRB')")
        loaded = from_study(arguments.study, arguments.structure)
        measurement = loaded.measurement
        source = f"{arguments.structure} of {arguments.study} ({measurement.provenance})"
        record = {"study": str(arguments.study), "structure": arguments.structure, "provenance": measurement.provenance,
                  "borrowed_damping": loaded.borrowed_damping, "damping_rule": loaded.damping_rule,
                  "candidates": {model: len(c.labels) for model, c in loaded.candidates.items()}}
        loop = partial(structure_discrepancy_loop, measurement, loaded.candidates, loaded.borrowed_damping,
                       loaded.space, loaded.damping_rule)
        findings = {}
    else:
        measured = read_mode_backbone(arguments.file)
        measurement = backbone_levels(measured, arguments.levels, arguments.file)
        frequency = arguments.nominal_frequency_hz or float(measurement.frequency_hz[0])
        damping = arguments.nominal_damping if arguments.nominal_damping is not None else float(measurement.damping[0])
        source = f"{arguments.file} ({measured.provenance})"
        record = {"source": str(arguments.file), "provenance": measured.provenance, "nominal_frequency_hz": frequency,
                  "nominal_damping": damping}
        loop = partial(discrepancy_loop, measurement, frequency, damping)
        findings = measured.findings
    with stage_folder(arguments.out) as out:
        verdict = with_findings(loop(), findings.get("found", []))
        record["signal_checks"] = findings.get("checked", [])
        write_verdict(out, verdict, measurement, source, record)
    seen = [entry["name"] for entry in verdict.findings]
    print(f"{source}: effects {verdict.effects or 'none'}{'; findings ' + ', '.join(seen) if seen else ''}"
          f"{' (unexplained)' if verdict.unexplained else ''}; wrote {out / 'discrepancy.md'}")


def register(subparsers) -> None:
    """Add the ``discrepancy`` subcommand."""
    command = subparsers.add_parser(
        "discrepancy", help="what the model of a measured mode lacks: effects found, errors before and after",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("file", type=Path, nargs="?", help=f"a measured backbone: {known_formats(BACKBONE)}")
    command.add_argument("--study", type=Path, help="a surrogacy study's folder: the loop on a structure's "
                                                    "superelement from the study's Pareto designs (with --structure)")
    command.add_argument("--structure", help="the study's structure, e.g. 'ASB C1' or 'LBRB'")
    command.add_argument("--nominal-frequency-hz", type=float, help="the model's low-amplitude frequency, Hz")
    command.add_argument("--nominal-damping", type=float, help="the model's linear damping ratio")
    command.add_argument("--levels", type=int, default=N_LEVELS, help="amplitude levels the measurement is binned to")
    command.add_argument("--out", type=Path, default=Path("results/discrepancy"), help="output folder")
    command.set_defaults(run=run)
