"""``surrogacy fit --study FOLDER``: calibrate each friction model of a finished study on each of its structures
(global NSGA-II to a front that stops moving, least-squares polishes along it, the best compromise with its
uncertainty and a fitted zeta_0), seeded with the study's Pareto designs. Files: ``calibration.files``."""

from __future__ import annotations

import argparse
from pathlib import Path

from calibration.calibrate import MAX_GENERATIONS
from calibration.workflow import calibrate_study


def run(arguments: argparse.Namespace) -> None:
    """Calibrate the study's models on its structures; each (model, structure) once, skipped on a rerun."""
    out = calibrate_study(arguments.study, arguments.out, arguments.models, arguments.structures, arguments.seed,
                          arguments.max_generations)
    print(f"wrote {out / 'calibration.md'}, front_<model>.csv, fits_<model>.png and <model>/<structure>.json")


def register(subparsers) -> None:
    """Add the ``fit`` subcommand."""
    command = subparsers.add_parser("fit", help="calibrate joint designs to the measured backbones of a study",
                                    description=__doc__)
    command.add_argument("--study", type=Path, required=True, help="a finished study's folder (surrogacy study)")
    command.add_argument("--models", nargs="+", help="friction models to calibrate (default: the study's)")
    command.add_argument("--structures", nargs="+", help="structures to calibrate on (default: the study's)")
    command.add_argument("--seed", type=int, default=0, help="NSGA-II's random seed (plus the structure's index)")
    command.add_argument("--max-generations", type=int, default=MAX_GENERATIONS,
                         help="cap of the global phase's generations (it stops earlier when its front stops moving)")
    command.add_argument("--out", type=Path, default=Path("results/fit"), help="output folder")
    command.set_defaults(run=run)
