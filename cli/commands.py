"""``surrogacy demo``: every stage end to end (:mod:`cli.demo`), the measured-data stages skipped where their data
is absent; ``make demo`` calls it."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from cli import demo


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
