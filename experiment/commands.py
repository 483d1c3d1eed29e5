"""Subcommands of the experiment stage for the ``surrogacy`` console script.

``surrogacy freevib FILE --mode-hz F``: amplitude-dependent natural frequency and damping of one mode from a
measured ring-down (paper section 3.1, Fig. 3), written as a CSV with units, a PNG plot and a JSON sidecar with
the resolved settings.
"""

from __future__ import annotations

import argparse
import inspect
from pathlib import Path

import numpy as np

from experiment.backbone import ringdown_backbone
from experiment.backbone_files import plot_backbone, write_freevib_table
from experiment.hilbert import OPTION_MINIMA, freevib
from experiment.ringdown import RingDown, RingDownError
from experiment.ringdown_files import read_ringdown
from pipeline.files import check_output_folder, sha256_file, write_json


def keyword_defaults(function) -> dict:
    """Defaults of a function's keyword arguments: the single source of the command-line defaults."""
    return {name: parameter.default for name, parameter in inspect.signature(function).parameters.items()
            if parameter.default is not inspect.Parameter.empty}


def read_mode_shapes(path: Path) -> np.ndarray:
    """Mode shapes at the sensors from a CSV of n_channels rows and n_modes columns (``#`` comments allowed)."""
    try:
        return np.loadtxt(path, delimiter=",", ndmin=2, comments="#")
    except (OSError, ValueError) as error:
        raise RingDownError(path, "mode shapes", f"not a readable table of numbers: {error}") from error


def check_options(arguments: argparse.Namespace) -> tuple[float, float]:
    """The band-pass edges (Hz), after refusing options out of range before the file is read, each named as
    typed: a mode frequency that is not a positive finite number was reported as a band beyond the Nyquist
    frequency, an inverted band likewise, and --grid-points or --cycles of 0 ended in a traceback. Raises
    ValueError."""
    def refuse(option: str, value, expected: str) -> None:
        raise ValueError(f"option {option} = {value!r}: expected {expected}")

    if not (np.isfinite(arguments.mode_hz) and arguments.mode_hz > 0):
        refuse("--mode-hz", arguments.mode_hz, "a positive natural frequency in Hz")
    band = tuple(arguments.band) if arguments.band else (0.7 * arguments.mode_hz, 1.3 * arguments.mode_hz)
    if arguments.band and not (np.all(np.isfinite(band)) and 0 < band[0] < arguments.mode_hz < band[1]):
        refuse("--band", list(band), f"finite edges LOW < HIGH in Hz around --mode-hz {arguments.mode_hz:g}")
    for option, value, minimum in (("--grid-points", arguments.grid_points, 2), ("--cycles", arguments.cycles, 1),
                                   ("--mode-index", arguments.mode_index, 1)):
        if value < minimum:
            refuse(option, value, f"an integer >= {minimum}")
    for option, value, minimum in (("--smoothing-periods", arguments.smoothing_periods,
                                    OPTION_MINIMA["smoothing_periods"]),
                                   ("--trim-periods", arguments.trim_periods, OPTION_MINIMA["trim_periods"])):
        if not (np.isfinite(value) and value >= minimum):
            refuse(option, value, f"a finite number of periods >= {minimum:g}")
    check_output_folder(arguments.out)
    return band


def check_nyquist(hits: list[RingDown], band: tuple[float, float]) -> None:
    """Refuse a band-pass that reaches a hit's Nyquist frequency, naming the file and the options that set it."""
    for hit in hits:
        if band[1] >= hit.sample_rate / 2:
            raise RingDownError(hit.source, "time", f"sampled at {hit.sample_rate:g} Hz: the band {band[0]:g}-"
                                f"{band[1]:g} Hz set by --mode-hz / --band must lie below its Nyquist frequency "
                                f"{hit.sample_rate / 2:g} Hz")


def run_freevib(arguments: argparse.Namespace) -> None:
    """Extract, write and plot the backbone of one mode of a ring-down file."""
    band = check_options(arguments)
    source = Path(arguments.file)
    hits = read_ringdown(source)
    check_nyquist(hits, band)
    backbone = ringdown_backbone(
        hits, arguments.mode_hz, band_hz=band,
        mode_shapes=read_mode_shapes(arguments.mode_shapes) if arguments.mode_shapes else None,
        mode_index=arguments.mode_index - 1, per_channel=arguments.per_channel, channels=arguments.channels,
        grid_points=arguments.grid_points, cycles=arguments.cycles, smoothing_periods=arguments.smoothing_periods,
        trim_periods=arguments.trim_periods, feldman=arguments.feldman)
    out = Path(arguments.out)
    stem = f"{source.stem}_mode_{arguments.mode_hz:g}Hz"
    write_freevib_table(backbone, out / f"{stem}.csv")
    plot_backbone(backbone, out / f"{stem}.png")
    settings = {key: value for key, value in vars(arguments).items() if key not in ("run", "run_log")}
    write_json(out / f"{stem}.json", {
        "source": str(source), "source_sha256": sha256_file(source), "settings": settings,
        "amplitude_unit": backbone.amplitude_unit, "records": [record.label for record in backbone.records],
        "mode_shape": {name: float(value) for name, value in backbone.shape.items()}})
    print(f"wrote {out / stem}.csv, .png, .json ({len(backbone.records)} records)")


def register(subparsers) -> None:
    """Add the experiment stage's subcommands to the ``surrogacy`` argument parser."""
    defaults = keyword_defaults(freevib) | keyword_defaults(ringdown_backbone)
    command = subparsers.add_parser(
        "freevib", help="amplitude-dependent frequency and damping from a ring-down (Hilbert / FreeVib)",
        description=run_freevib.__doc__ + " Writes <stem>_mode_<F>Hz.csv (with units), .png and .json to --out.")
    command.add_argument("file", help="ring-down file: .csv, .mat or .uff/.unv (dataset 58)")
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
    command.add_argument("--out", default="results/freevib", help="output folder")
    command.set_defaults(run=run_freevib)
