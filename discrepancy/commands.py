"""``surrogacy discrepancy``: what the model of a measured mode lacks, with the effects found, the evidence and the
errors before and after.

Two models:

``surrogacy discrepancy FILE``: a backbone CSV (a ring-down is processed into one by ``surrogacy freevib``) or an
ASB measured backbone (.mat with Q, W, Z), with the one-mode joint model (``discrepancy.loop``) for measurements with no
finite-element model behind them, at the nominal low-amplitude frequency and linear damping of the structure's
model (``--nominal-frequency-hz``, ``--nominal-damping``; default: the measurement's own low-amplitude values,
weighted lines through its lowest decade of amplitude extrapolated to zero amplitude, with their standard errors
(``discrepancy.nominal``), so that only the amplitude dependence is questioned).

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
from pathlib import Path

import numpy as np

from discrepancy.files import read_final_model, verdict_summary, write_model_curve
from discrepancy.nominal import NominalError, checked_nominal
from discrepancy.workflow import measured_input, run_loop, study_input
from experiment.measured_files import BACKBONE, known_formats
from pipeline.files import stage_folder
from study.structures import MIN_POINTS, N_LEVELS

NOMINAL_OPTIONS = {"frequency_hz": "--nominal-frequency-hz", "damping": "--nominal-damping"}
"""Parameter of ``discrepancy.nominal.checked_nominal`` -> the option that sets it."""


def check_options(arguments: argparse.Namespace) -> None:
    """Refuse options out of range before any file is read or written, each named as typed: the nominal
    (``discrepancy.nominal.checked_nominal``) and fewer --levels than a measurement needs. Raises ValueError."""
    try:
        checked_nominal(arguments.nominal_frequency_hz, arguments.nominal_damping)
    except NominalError as error:
        raise ValueError(f"option {NOMINAL_OPTIONS[error.parameter]} = {error.value!r}: expected "
                         f"{error.expected}") from None
    given = [option for name, option in NOMINAL_OPTIONS.items()
             if getattr(arguments, f"nominal_{name}") is not None]
    if arguments.study is not None and given:
        raise ValueError(f"option {given[0]} applies to FILE (a measured backbone); with --study the nominal is the "
                         "structure's superelement and the study's fits")
    if arguments.levels < MIN_POINTS:
        raise ValueError(f"option --levels = {arguments.levels!r}: expected an integer >= {MIN_POINTS} (amplitude "
                         "levels the measurement is binned to)")


def run(arguments: argparse.Namespace) -> None:
    """Run the loop on one measured backbone (FILE, one-mode model) or on a study's structure (its superelement
    and the study's fits) and write its report."""
    if (arguments.file is None) == (arguments.study is None):
        raise ValueError("give either FILE (a measured backbone) or --study FOLDER --structure NAME")
    check_options(arguments)
    if arguments.study is not None:
        if arguments.structure is None:
            raise ValueError("--study needs --structure NAME (e.g. 'ASB C1' or 'LBRB')")
        loop_input = study_input(arguments.study, arguments.structure)
    else:
        loop_input = measured_input(arguments.file, arguments.levels, arguments.nominal_frequency_hz,
                                    arguments.nominal_damping)
    with stage_folder(arguments.out) as out:
        verdict, record = run_loop(loop_input, out)
    seen = [entry["name"] for entry in verdict.findings]
    print(f"{loop_input.source}: {verdict_summary(verdict.joint_law, verdict.added, verdict.alternatives)}"
          f"{'; findings ' + ', '.join(seen) if seen else ''}"
          f"{' (unexplained)' if verdict.unexplained else ''}"
          + ("; nominal estimated from the file: it holds any offset at every amplitude (see discrepancy.md)"
             if record.get("nominal_caveat") else "") + f"; wrote {out / 'discrepancy.md'}")


def run_model(arguments: argparse.Namespace) -> None:
    """Evaluate the one-mode final model a ``surrogacy discrepancy`` run wrote (its discrepancy.json) at
    amplitudes, with its 95 % band, each marked fitted range or extrapolation; write a CSV."""
    low, high = arguments.amplitudes
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
        raise ValueError(f"option --amplitudes = {low!r} {high!r}: expected 0 < LOW < HIGH, finite")
    if arguments.points < 2:
        raise ValueError(f"option --points = {arguments.points!r}: expected an integer >= 2")
    source = Path(arguments.verdict)
    amplitude = np.geomspace(low, high, arguments.points)
    destination = Path(arguments.out)
    curve = write_model_curve(read_final_model(source), source, amplitude, destination)
    print(f"wrote {destination}: {int(curve['extrapolated'].sum())} of {amplitude.size} amplitudes outside the "
          f"fitted range (extrapolation)")


def register(subparsers) -> None:
    """Add the ``discrepancy`` and ``discrepancy-model`` subcommands."""
    model = subparsers.add_parser(
        "discrepancy-model", help="evaluate the final one-mode model of a discrepancy run, with its band",
        description=run_model.__doc__)
    model.add_argument("verdict", help="discrepancy.json of a one-mode run (FILE given to surrogacy discrepancy)")
    model.add_argument("--amplitudes", type=float, nargs=2, required=True, metavar=("LOW", "HIGH"),
                       help="amplitude range, in the measurement's unit (log-spaced)")
    model.add_argument("--points", type=int, default=50, help="amplitudes in the range")
    model.add_argument("--out", default="results/discrepancy/model.csv", help="CSV to write")
    model.set_defaults(run=run_model)
    command = subparsers.add_parser(
        "discrepancy", help="what the model of a measured mode lacks: effects found, errors before and after",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("file", type=Path, nargs="?", help=f"a measured backbone: {known_formats(BACKBONE)}")
    command.add_argument("--study", type=Path, help="a surrogacy study's folder: the loop on a structure's "
                                                    "superelement from the study's Pareto designs (with --structure)")
    command.add_argument("--structure", help="the study's structure, e.g. 'ASB C1' or 'LBRB'")
    command.add_argument("--nominal-frequency-hz", type=float,
                         help="the model's low-amplitude frequency, Hz (positive; default: the measurement's, "
                              "extrapolated to zero amplitude from its lowest decade)")
    command.add_argument("--nominal-damping", type=float,
                         help="the model's linear damping ratio, in [0, 1) (default: the measurement's, "
                              "extrapolated to zero amplitude from its lowest decade)")
    command.add_argument("--levels", type=int, default=N_LEVELS, help="amplitude levels the measurement is binned to")
    command.add_argument("--out", type=Path, default=Path("results/discrepancy"), help="output folder")
    command.set_defaults(run=run)
