"""``surrogacy study``: the surrogacy study of one dataset, step by step (docs/design.md section 7).

Steps (``--steps``, default all, in this order; each reads the files the previous one wrote, so a user can stop
after any step and inspect them):

measurements  <out>/measurements/<structure>.csv: the backbones to fit in the documented backbone format
              (``experiment.backbone_files``); for the beams the virtual experiments (with their generating
              configuration, labelled virtual), for the ASB its measured backbones.
explore       <out>/designs/<model>/chunk-<c>.parquet: every design of the replicated Latin hypercube on
              every structure, two L-infinity errors per structure, flags and reasons
              (``study.exploration``); resumes where a killed run stopped; ``--scheduler`` farms chunks to
              a dask.distributed cluster (``local`` for a LocalCluster on this machine).
analyse       <out>/analysis/: surrogacy matrices with intervals (CSV, Markdown), their sensitivity to the
              acceptance bounds, Pareto fronts of the sample and of NSGA-II, representative responses,
              the ANOVA (beams), the prestress comparison (beams).
report        <out>/report.md with the figures.

Configuration: ``--config study.toml`` with tables [study], [sample], [acceptance], [pareto], and
``--set SECTION.FIELD=VALUE`` (e.g. ``--set sample.n_designs=100000``). The resolved configuration, the seed
and the versions are written to <out>/study.json.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config import add_config_arguments, configuration
from pipeline.files import stage_folder
from study import workflow
from study.parameters import defaults

def run(arguments: argparse.Namespace) -> None:
    """Run the chosen steps of the study."""
    parameters = configuration(arguments, defaults())
    paths = workflow.Paths(Path(arguments.out), Path(arguments.rom), Path(arguments.data), Path(arguments.reference))
    with stage_folder(arguments.out):
        for step, result in workflow.run_steps(paths, parameters, arguments.steps, arguments.scheduler,
                                               arguments.restart_stale):
            if step == "report":
                print(f"wrote {result}")


def register(subparsers) -> None:
    """Add the ``study`` subcommand."""
    command = subparsers.add_parser(
        "study", help="surrogacy study: designs, errors, surrogacy matrices, Pareto fronts, ANOVA, report",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--out", type=Path, default=Path("results/study-beams"), help="results folder")
    command.add_argument("--rom", type=Path, default=Path("build/rom"), help="reduction stage output (beams)")
    command.add_argument("--data", type=Path, default=Path("../shared/data"),
                         help="folder with asb-backbones/ and asb-reduced-models/ (ASB dataset)")
    command.add_argument("--reference", type=Path, default=Path("../shared/reference"),
                         help="folder with the paper's tables (Table 1 damping, Tables 5-6 for comparison)")
    command.add_argument("--steps", nargs="+", choices=workflow.STEPS, default=list(workflow.STEPS), help="steps to run, in order")
    command.add_argument("--scheduler", help="dask.distributed scheduler address, or 'local' for a LocalCluster "
                                             "(default: evaluate in this process)")
    command.add_argument("--restart-stale", action="store_true",
                         help="discard design chunks written for other inputs (a changed measurement, superelement "
                              "or sample) and recompute them, instead of refusing the folder")
    add_config_arguments(command, "[study], [sample], [acceptance], [pareto]", "sample.n_designs=20000")
    command.set_defaults(run=run)
