"""``surrogacy demo``: every stage end to end (:mod:`pipeline.demo`), the measured-data stages skipped where their
data is absent; ``make demo`` calls it. ``surrogacy data fetch``: the public measured data
(:mod:`pipeline.public_data`); ``make data`` calls it."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from pipeline import demo, public_data


def run(arguments: argparse.Namespace) -> None:
    """Plan the demo's steps and run them; a failed stage's exit status is the demo's."""
    options = demo.DemoOptions(arguments.data, arguments.reference, arguments.ringdown, arguments.mode_hz,
                               arguments.designs, arguments.chunk, arguments.scheduler, arguments.run_log)
    steps = [step for step in demo.plan(options) if step.name in arguments.steps]
    try:
        demo.run_steps(steps, options)
    except subprocess.CalledProcessError as error:
        print(f"surrogacy demo: {error.cmd if isinstance(error.cmd, str) else 'a stage'} failed "
              f"(exit {error.returncode})", file=sys.stderr)
        raise SystemExit(error.returncode) from None


def register(subparsers) -> None:
    """Add the ``demo`` subcommand."""
    defaults = demo.DemoOptions(Path("data"), None, Path("data/chen2022-brb-hammer/HammerImpact.mat"), 80.5)
    command = subparsers.add_parser("demo", help="every stage end to end, ending with results/report.md",
                                    description=demo.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--data", type=Path, default=defaults.data,
                         help="folder with asb-backbones/ and asb-reduced-models/ (ASB study; skipped if absent; "
                              "default data/, where surrogacy data fetch puts them)")
    command.add_argument("--reference", type=Path, metavar="FOLDER",
                         help="a folder whose paper_table{1,3,5,6}_*.csv replace the paper's tables in the studies "
                              "(default: the paper's, in pipeline/published.py)")
    command.add_argument("--ringdown", type=Path, default=defaults.ringdown,
                         help="measured ring-down for freevib and the one-mode discrepancy loop (skipped if absent; "
                              "default the Chen 2022 ring-down in data/)")
    command.add_argument("--mode-hz", type=float, default=defaults.mode_hz, help="the ring-down's mode, Hz")
    command.add_argument("--designs", type=int, default=defaults.designs, help="designs per friction model")
    command.add_argument("--chunk", type=int, default=defaults.chunk, help="designs per chunk")
    command.add_argument("--scheduler", help="dask.distributed address or 'local' for the studies")
    command.add_argument("--steps", nargs="+", choices=demo.STEPS, default=list(demo.DEMO_STEPS),
                         help="steps to run, in the demo's order (default all but discrepancy-modal-asb, "
                              "fit-beams, confidence-asb and confidence-beams)")
    command.set_defaults(run=run)
    register_data(subparsers)


def fetch(arguments: argparse.Namespace) -> None:
    """Download the public measured files into ``arguments.out``, hashes checked."""
    paths = public_data.fetch(arguments.out, arguments.base_url, retries=arguments.retries,
                              progress=not arguments.quiet)
    print(f"{len(paths)} files in {arguments.out}: ASB data --data {arguments.out}, ring-down --ringdown "
          f"{arguments.out / 'chen2022-brb-hammer' / 'HammerImpact.mat'}")


def register_data(subparsers) -> None:
    """Add the ``data`` subcommand (``data fetch``)."""
    command = subparsers.add_parser("data", help="the public measured data: fetch it, hashes checked",
                                    description=public_data.__doc__,
                                    formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = command.add_subparsers(dest="action", required=True, metavar="ACTION")
    action = actions.add_parser("fetch", help="download every public file (ASB backbones and reduced models, the "
                                              "Chen 2022 ring-down) into a folder, each SHA-256 checked")
    action.add_argument("--out", type=Path, default=Path("data"), help="the data folder (default data/)")
    action.add_argument("--base-url", help="a mirror holding the files under their names here (default "
                                           f"${public_data.BASE_URL_VARIABLE}, else the public sources)")
    action.add_argument("--retries", type=int, default=2, help="further attempts of a failed download")
    action.add_argument("--quiet", action="store_true", help="no progress bars")
    action.set_defaults(run=fetch)
