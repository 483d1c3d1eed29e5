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

Configuration: ``--config study.toml`` with tables [study], [sample], [acceptance], [pareto], [compute], and
``--set SECTION.FIELD=VALUE`` (e.g. ``--set sample.n_designs=100000``). The resolved configuration, the seed
and the versions are written to <out>/study.json.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nonlinear.compute_devices import DEVICES, check_device
from pipeline.config import add_config_arguments, configuration
from pipeline.files import stage_folder
from pipeline.runners import on_this_machine
from study import workflow
from study.confidence import estimate_inputs, surrogacy_confidence
from study.parameters import defaults
from study.subset_simulation import Settings


def run(arguments: argparse.Namespace) -> None:
    """Run the chosen steps of the study; the compute device checked first where this machine evaluates designs
    (the analyse step, and the explore step without a remote scheduler)."""
    parameters = configuration(arguments, defaults())
    if "analyse" in arguments.steps or ("explore" in arguments.steps and on_this_machine(arguments.scheduler)):
        check_device(parameters["compute"].device, "[compute] device")
    paths = workflow.Paths(Path(arguments.out), Path(arguments.rom), Path(arguments.data), arguments.reference)
    with stage_folder(arguments.out):
        for step, result in workflow.run_steps(paths, parameters, arguments.steps, arguments.scheduler,
                                               arguments.restart_stale):
            if step == "explore" and result.timings:
                files = sum(len(timing.models) for timing in result.timings)
                print(f"explored {len(result.timings)} chunk(s) ({files} chunk files) in {result.wall_seconds:.0f} s "
                      f"on {result.threads} worker thread(s), idle {result.idle_fraction:.1%} of their time")
            if step == "report":
                print(f"wrote {result}")


def register(subparsers) -> None:
    """Add the ``study`` subcommand."""
    command = subparsers.add_parser(
        "study", help="surrogacy study: designs, errors, surrogacy matrices, Pareto fronts, ANOVA, report",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--out", type=Path, default=Path("results/study-beams"), help="results folder")
    command.add_argument("--rom", type=Path, default=Path("build/rom"), help="reduction stage output (beams)")
    command.add_argument("--data", type=Path, default=Path("data"),
                         help="folder with asb-backbones/ and asb-reduced-models/ (ASB dataset; default data/, where "
                              "surrogacy data fetch puts them)")
    command.add_argument("--reference", type=Path, metavar="FOLDER",
                         help="a folder whose paper_table{1,3,5,6}_*.csv replace the paper's Tables 1, 3, 5 and 6 "
                              "(default: the paper's, in pipeline/published.py)")
    command.add_argument("--steps", nargs="+", choices=workflow.STEPS, default=list(workflow.STEPS), help="steps to run, in order")
    command.add_argument("--scheduler", help="dask.distributed scheduler address, or 'local' for a LocalCluster "
                                             "(default: evaluate in this process)")
    command.add_argument("--restart-stale", action="store_true",
                         help="discard design chunks written for other inputs (a changed measurement, superelement "
                              "or sample) and recompute them, instead of refusing the folder")
    add_config_arguments(command, "[study], [sample], [acceptance], [pareto], [compute]",
                         "sample.n_designs=20000 or compute.device=cuda")
    command.set_defaults(run=run)
    register_confidence(subparsers)


def add_device_argument(command: argparse.ArgumentParser) -> None:
    """Add ``--device``, the compute device of a command that reads a finished study (``study.workflow.read_study``)."""
    command.add_argument("--device", choices=DEVICES,
                         help="where the stuck modes and QSMA levels are solved (default: the study's compute.device; "
                              "the results agree to round-off)")


CONFIDENCE_DESCRIPTION = """``surrogacy confidence``: SC_IJ at acceptance bounds where random designs rarely fall into a
surrogate's acceptance region, by subset simulation (``study.confidence``; docs/design.md section 7).

Reads a study's folder (its study.json and measurements/; the exploration itself is not needed), samples the
designs of one friction model that each surrogate (``--surrogate``, default every structure: the whole matrix)
accepts at the given bounds, and writes one CSV row per surrogate I and real structure J: SC_IJ with its interval,
effective sample size and families, P(accepted by I) with its c.o.v. and interval, the evaluations used and the
seed, the same for every surrogate (docs/formats.md). Each level's state is saved under
<out>.levels/<surrogate>/, so a killed run started again resumes from its last finished level. ``--scheduler``
spreads each batch of evaluations over a dask.distributed cluster, with the same numbers as in one process. A run
whose misfit threshold stalls short of the region is made again with twice the designs per level (``--restarts``
times at most); the CSV says how many each run used, and a surrogate still not reached gets a row saying why.
"""


def run_confidence(arguments: argparse.Namespace) -> None:
    """Subset simulation of each surrogate; writes the CSV (with the study's own sample counted at the same
    bounds beside it where the sample exists) and prints its main columns."""
    estimate = estimate_inputs(arguments.study, arguments.model, arguments.out, arguments.damping_case,
                               arguments.bounds, arguments.frequency_bound, arguments.damping_bound, arguments.device)
    if on_this_machine(arguments.scheduler):
        workflow.check_reader_device(estimate.folder)
    settings = Settings(arguments.seed, arguments.per_level, arguments.level_probability, arguments.conditional,
                        restarts=arguments.restarts)
    table, figure = surrogacy_confidence(estimate.folder, arguments.model, estimate.case, estimate.frequency_bounds,
                                         estimate.damping_bounds, settings, arguments.out, arguments.surrogate,
                                         arguments.scheduler)
    for row in table[table["runs"].isna()].drop_duplicates("surrogate").itertuples():  # the region not reached
        print(f"{row.surrogate}: not estimated: {row.note}")
    if figure is not None:
        print(f"wrote {figure}")
    print(table[["surrogate", "real", "confidence", "lower", "upper", "sample_confidence", "families",
                 "surrogate_probability", "designs_per_level", "evaluations"]].to_string(index=False))
    print(f"wrote {arguments.out}")


def register_confidence(subparsers) -> None:
    """Add the ``confidence`` subcommand."""
    settings = Settings()
    command = subparsers.add_parser(
        "confidence", help="surrogacy confidence of one surrogate at tight acceptance bounds (subset simulation)",
        description=CONFIDENCE_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--study", type=Path, required=True, help="folder of a study (surrogacy study --out)")
    command.add_argument("--model", required=True, help="friction model of the study")
    command.add_argument("--surrogate", nargs="+", help="structures I (names in the study; default: every one)")
    command.add_argument("--frequency-bound", type=float, help="acceptance bound of e_f (Hz), every structure")
    command.add_argument("--damping-bound", type=float, help="acceptance bound of e_zeta (-), every structure")
    command.add_argument("--bounds", type=Path, help="each structure's bounds from a bounds CSV (surrogacy fit's "
                                                     "bounds.csv: from the calibrated optimum and the measurement)")
    command.add_argument("--damping-case", help="linear damping case of the study (default: the study's default)")
    command.add_argument("--seed", type=int, default=settings.seed, help="seed of the sampler's numpy Generator")
    command.add_argument("--per-level", type=int, default=settings.n_per_level, help="designs per level")
    command.add_argument("--level-probability", type=float, default=settings.level_probability,
                         help="conditional probability between levels")
    command.add_argument("--conditional", type=int, default=settings.n_conditional,
                         help="designs drawn in the surrogate's acceptance region for SC")
    command.add_argument("--restarts", type=int, default=settings.restarts,
                         help="how often a run whose misfit threshold stalls is made again with twice the designs per "
                              "level")
    command.add_argument("--scheduler", help="dask.distributed scheduler address, or 'local' for a LocalCluster "
                                             "(default: evaluate in this process)")
    command.add_argument("--out", type=Path, required=True, help="CSV file to write")
    add_device_argument(command)
    command.set_defaults(run=run_confidence)
