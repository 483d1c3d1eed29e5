"""``surrogacy fit --study FOLDER``: calibrate each friction model of a finished study on each of its structures
(global NSGA-II to a front that stops moving, least-squares polishes along it, a deterministic multistart, the best
compromise with its uncertainty and a fitted zeta_0), seeded with the study's Pareto designs. With ``--replicates
STUDY ...`` (studies of the same inputs at other seeds) each is calibrated too and the spread of every best
compromise's chi^2 over the seeds is reported. Files: ``calibration.files``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from calibration.calibrate import MAX_GENERATIONS
from calibration.workflow import calibrate_replicates, calibrate_study
from study.commands import add_device_argument


def run(arguments: argparse.Namespace) -> None:
    """Calibrate the study's models on its structures (and the replicate studies'); each (model, structure) once,
    skipped on a rerun; a nested model worse than one it contains is named on stderr."""
    options = (arguments.models, arguments.structures, arguments.seed, arguments.max_generations, arguments.device)
    replicates, defects = calibrate_replicates(arguments.replicates or (), arguments.study, arguments.out,
                                               *options)
    out, found = calibrate_study(arguments.study, arguments.out, *options, replicates=replicates)
    for line in defects + found:
        print(f"defect: {line}", file=sys.stderr)
    print(f"wrote {out / 'calibration.md'}, front_<model>.csv, fits_<model>.png and <model>/<structure>.json"
          + (f", spread.csv and replicates/seed-<seed>/ of seeds {', '.join(map(str, replicates))}"
             if replicates else ""))


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
    command.add_argument("--replicates", type=Path, nargs="+",
                         help="studies of the same inputs at other seeds: each calibrated into OUT/replicates/"
                              "seed-<seed>, and the spread of every best compromise's chi^2 over the seeds reported")
    command.add_argument("--out", type=Path, default=Path("results/fit"), help="output folder")
    add_device_argument(command)
    command.set_defaults(run=run)
