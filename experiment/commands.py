"""Subcommands of the experiment stage for the ``surrogacy`` console script.

``surrogacy freevib FILE --mode-hz F``: amplitude-dependent natural frequency and damping of one mode from a
measured ring-down (paper section 3.1, Fig. 3), written as the backbone CSV that the study, the discrepancy loop
and the report read (the settings and the findings of the signal checks recorded in it), a table of both
estimators, a PNG plot and a JSON sidecar with the resolved settings.
"""

from __future__ import annotations

import argparse
import inspect
from pathlib import Path

from experiment.backbone import BackboneSettingError, check_nyquist, checked_settings, ringdown_backbone
from experiment.backbone_files import write_freevib
from experiment.hilbert import freevib
from experiment.measured_files import RING_DOWN, known_formats, read_ringdown, stated_provenance
from experiment.ringdown_analysis import analyse_ringdown_file
from experiment.ringdown_files import read_mode_shapes
from pipeline.files import check_output_folder


def keyword_defaults(function) -> dict:
    """Defaults of a function's keyword arguments: the single source of the command-line defaults."""
    return {name: parameter.default for name, parameter in inspect.signature(function).parameters.items()
            if parameter.default is not inspect.Parameter.empty}


OPTIONS = {"mode_frequency_hz": "mode_hz", "band_hz": "band", "grid_points": "grid_points", "cycles": "cycles",
           "smoothing_periods": "smoothing_periods", "trim_periods": "trim_periods"}
"""Setting of ``experiment.backbone.checked_settings`` -> the option (argparse dest) that sets it."""


def check_options(arguments: argparse.Namespace) -> tuple[float, float]:
    """The band-pass edges (Hz), after refusing options out of range before the file is read
    (``experiment.backbone.checked_settings``), each named as typed. Raises ValueError."""
    if arguments.mode_index < 1:
        raise ValueError(f"option --mode-index = {arguments.mode_index!r}: expected an integer >= 1")
    try:
        band = checked_settings(arguments.mode_hz, arguments.band, arguments.grid_points, arguments.cycles,
                                arguments.mode_index - 1, arguments.smoothing_periods, arguments.trim_periods)
    except BackboneSettingError as error:
        option = OPTIONS[error.parameter]
        raise ValueError(f"option --{option.replace('_', '-')} = {error.value!r}: expected "
                         f"{error.expected.replace('the mode frequency', '--mode-hz')}") from None
    check_output_folder(arguments.out)
    return band


def resolved_provenance(source: Path, declared: str | None) -> str:
    """The provenance of the backbone: what the file states (``experiment.measured_files``), or what the user
    declares where the file does not say; a declaration the file contradicts raises ValueError."""
    stated = stated_provenance(source)
    if declared is not None and stated not in ("unknown", declared):
        raise ValueError(f"option --provenance = {declared}: {source} states its data {stated}")
    return stated if stated != "unknown" else declared or "unknown"


def run_freevib(arguments: argparse.Namespace) -> None:
    """Extract, write and plot the backbone of one mode of a ring-down file, and check its signals for what the
    backbone hides (a second mode, a drift over the hits, clipping, no pre-trigger, a truncated record)."""
    band = check_options(arguments)
    source = Path(arguments.file)
    hits = read_ringdown(source)
    provenance = resolved_provenance(source, arguments.provenance)
    check_nyquist(hits, band, "--mode-hz / --band")
    settings = {key: value for key, value in vars(arguments).items()  # how, not what or where
                if key not in ("run", "run_log", "command", "file", "out")}
    labelled, backbone = analyse_ringdown_file(
        source, hits, arguments.mode_hz, provenance, settings, band_hz=band,
        mode_shapes=read_mode_shapes(arguments.mode_shapes) if arguments.mode_shapes else None,
        mode_index=arguments.mode_index - 1, per_channel=arguments.per_channel, channels=arguments.channels,
        grid_points=arguments.grid_points, cycles=arguments.cycles, smoothing_periods=arguments.smoothing_periods,
        trim_periods=arguments.trim_periods, feldman=arguments.feldman, seed=arguments.seed)
    findings = labelled.findings
    out = Path(arguments.out)
    stem = write_freevib(out, source, arguments.mode_hz, labelled, backbone)
    for entry in labelled.dropped:
        print(f"left out of the backbone: the point at amplitude {entry['amplitude']:.4g} {backbone.amplitude_unit} "
              f"({entry['records']} record(s)): {entry['reason']}")
    for entry in findings["found"]:
        print(f"finding {entry['name']}: {entry['summary']}")
    print(f"wrote {out / stem}_backbone.csv (the backbone the study and the discrepancy loop read), "
          f"{stem}.csv (both estimators), .png, .json ({len(backbone.records)} records; checked "
          f"{', '.join(findings['checked'])}: {len(findings['found'])} finding(s))")


def register(subparsers) -> None:
    """Add the experiment stage's subcommands to the ``surrogacy`` argument parser."""
    defaults = keyword_defaults(freevib) | keyword_defaults(ringdown_backbone)
    command = subparsers.add_parser(
        "freevib", help="amplitude-dependent frequency and damping from a ring-down (Hilbert / FreeVib)",
        description=run_freevib.__doc__ + " Writes <stem>_mode_<F>Hz_backbone.csv (the backbone CSV), "
                    "<stem>_mode_<F>Hz.csv (both estimators, with units), .png and .json to --out.")
    command.add_argument("file", help=f"ring-down file: {known_formats(RING_DOWN)}")
    command.add_argument("--mode-hz", type=float, required=True, help="guess of the mode's natural frequency, Hz")
    command.add_argument("--band", type=float, nargs=2, metavar=("LOW", "HIGH"),
                         help="band-pass edges, Hz (default 0.7 and 1.3 times --mode-hz)")
    command.add_argument("--mode-shapes", help="CSV of mode shapes at the channels (rows) for modal filtering; "
                                               "default: estimate the mode's shape from the band-passed channels")
    command.add_argument("--mode-index", type=int, default=1, help="column of --mode-shapes to keep (1-based)")
    command.add_argument("--per-channel", action="store_true",
                         help="treat each channel (scaled by its shape entry) as a record instead of combining them")
    command.add_argument("--channels", nargs="+", help="channels to use (default all)")
    command.add_argument("--grid-points", type=int, default=defaults["grid_points"],
                         help="points of the log amplitude grid")
    command.add_argument("--cycles", type=int, default=defaults["cycles"],
                         help="cycles per window of the cycle estimator")
    command.add_argument("--smoothing-periods", type=float, default=defaults["smoothing_periods"],
                         help="derivative smoothing window, periods")
    command.add_argument("--trim-periods", type=float, default=defaults["trim_periods"],
                         help="periods trimmed at each end of a decay")
    command.add_argument("--feldman", action="store_true", help="use Feldman's FreeVib corrections")
    command.add_argument("--seed", type=int, default=defaults["seed"],
                         help="seed of the twin decays' noise, whose spread is the backbone's standard error")
    command.add_argument("--provenance", choices=("measured", "virtual"),
                         help="what the data are, where the file does not say (default: the file's statement, or "
                              "unknown); refused where the file says otherwise")
    command.add_argument("--out", default="results/freevib", help="output folder")
    command.set_defaults(run=run_freevib)
