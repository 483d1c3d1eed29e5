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
import json
from functools import partial
from pathlib import Path

import numpy as np

from discrepancy.files import verdict_summary, write_verdict
from discrepancy.fitted_model import check_record, evaluate, model_record
from discrepancy.loop import discrepancy_loop, with_findings
from discrepancy.nominal import NominalError, checked_nominal, low_amplitude_nominal, offset_caveat
from discrepancy.superelement_route import from_study, structure_discrepancy_loop
from experiment.measured_files import BACKBONE, known_formats, read_mode_backbone
from pipeline.files import atomic_path, stage_folder
from reduction.superelement import StructureError
from experiment.backbone import unphysical_points
from study.structures import MIN_POINTS, N_LEVELS, measured_levels

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


def backbone_levels(measured, levels: int, path: Path):
    """The measured backbone binned to ``levels`` (``study.structures.measured_levels``). A point no free decay
    gives (``experiment.backbone.unphysical_points``: negative damping, no estimate, a frequency outside the band
    the settings name) raises StructureError naming the point and its cause; ``surrogacy freevib`` leaves such
    points out of the backbones it writes."""
    settings = measured.settings
    band = (settings.get("band") or ([0.7 * settings["mode_hz"], 1.3 * settings["mode_hz"]]
                                     if "mode_hz" in settings else None))
    reasons = unphysical_points(measured.backbone, band)
    if reasons:
        index, reason = next(iter(reasons.items()))
        raise StructureError(f"{path}: point {index + 1} of {measured.backbone.amplitude.size} (amplitude "
                             f"{measured.backbone.amplitude[index]:.4g} {measured.amplitude_unit}): {reason}"
                             + (f" (and {len(reasons) - 1} more such point(s))" if len(reasons) > 1 else "")
                             + "; remove its row, or rewrite the backbone with surrogacy freevib, which leaves such "
                               "points out with the reason")
    return measured_levels(measured, levels, str(path))


def nominal_record(measurement, frequency_hz: float | None, damping: float | None) -> dict:
    """The nominal the loop starts from: the given values, and for any not given the measurement's low-amplitude
    estimate (``discrepancy.nominal.low_amplitude_nominal``), with standard errors (0 for a given value), a
    ``nominal_source`` saying where they came from and a ``nominal_caveat`` saying which offsets an estimated
    nominal holds (``discrepancy.nominal.offset_caveat``; None where both were given)."""
    estimate = (low_amplitude_nominal(measurement) if frequency_hz is None or damping is None else None)
    given = [name for name, value in (("frequency", frequency_hz), ("damping", damping)) if value is not None]
    source = ("given" if len(given) == 2 else estimate.source if not given else
              f"{given[0]} given; {'damping' if given[0] == 'frequency' else 'frequency'} {estimate.source}")
    return {"nominal_frequency_hz": frequency_hz if frequency_hz is not None else estimate.frequency_hz,
            "nominal_frequency_standard_error_hz": 0.0 if frequency_hz is not None
            else estimate.frequency_standard_error_hz,
            "nominal_damping": damping if damping is not None else estimate.damping,
            "nominal_damping_standard_error": 0.0 if damping is not None else estimate.damping_standard_error,
            "nominal_source": source,
            "nominal_caveat": offset_caveat([name for name, value in (("frequency", frequency_hz),
                                                                        ("damping", damping)) if value is None])}


def run(arguments: argparse.Namespace) -> None:
    """Run the loop on one measured backbone (FILE, one-mode model) or on a study's structure (its superelement
    and the study's fits) and write its report."""
    if (arguments.file is None) == (arguments.study is None):
        raise ValueError("give either FILE (a measured backbone) or --study FOLDER --structure NAME")
    check_options(arguments)
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
        nominal = nominal_record(measurement, arguments.nominal_frequency_hz, arguments.nominal_damping)
        source = f"{arguments.file} ({measured.provenance})"
        record = {"source": str(arguments.file), "provenance": measured.provenance, **nominal,
                  "dropped_points": measured.dropped}
        loop = partial(discrepancy_loop, measurement, nominal["nominal_frequency_hz"], nominal["nominal_damping"],
                       nominal_uncertainty=(nominal["nominal_frequency_standard_error_hz"],
                                            nominal["nominal_damping_standard_error"]))
        findings = measured.findings
    with stage_folder(arguments.out) as out:
        verdict = with_findings(loop(), findings.get("found", []))
        record["signal_checks"] = findings.get("checked", [])
        if arguments.file is not None:
            record["final_model"] = {**model_record(verdict.final, measurement, record["nominal_frequency_hz"],
                                                    record["nominal_damping"]),
                                     "amplitude_unit": measured.amplitude_unit}
        write_verdict(out, verdict, measurement, source, record)
    seen = [entry["name"] for entry in verdict.findings]
    print(f"{source}: {verdict_summary(verdict.joint_law, verdict.added, verdict.alternatives)}"
          f"{'; findings ' + ', '.join(seen) if seen else ''}"
          f"{' (unexplained)' if verdict.unexplained else ''}"
          + (f"; nominal estimated from the file: it holds any offset at every amplitude (see discrepancy.md)"
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
    try:
        record = json.loads(source.read_text())["final_model"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{source}: field final_model: expected the discrepancy.json of a one-mode run of "
                         f"surrogacy discrepancy ({type(error).__name__}: {error})") from None
    check_record(record, str(source))
    amplitude = np.geomspace(low, high, arguments.points)
    curve = evaluate(record, amplitude)
    table = np.column_stack([amplitude, curve["frequency_hz"], *curve["frequency_band"], curve["damping"],
                             *curve["damping_band"], curve["extrapolated"]])
    destination = Path(arguments.out)
    with atomic_path(destination) as temporary:
        np.savetxt(temporary, table, delimiter=",", fmt="%.10g", comments="",
                   header=f"# model of {source} (effects: {', '.join(record['effects']) or 'none'}), fitted over "
                          f"amplitudes {record['fitted_range'][0]:.6g} to {record['fitted_range'][1]:.6g}; bands: "
                          "95 % of the parameters' uncertainty, linearised\n"
                          "amplitude,frequency [Hz],frequency low [Hz],frequency high [Hz],damping ratio [-],"
                          "damping low [-],damping high [-],extrapolation")
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
