"""``surrogacy study``: the surrogacy study of one dataset, step by step (DESIGN.md section 7).

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
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

from pipeline.cache import package_versions
from pipeline.config import add_config_arguments, configuration
from pipeline.files import stage_folder, write_json
from study import workflow
from study.datasets import DATASET_MODELS, DATASETS
from study.errors import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE_HZ
from study.exploration import Sample
from study.structures import N_LEVELS

STEPS = ("measurements", "explore", "analyse", "report")


@dataclass(frozen=True)
class StudyParameters:
    """[study]: dataset ("beams" or "asb"), friction models (default: all the dataset allows), levels per
    structure. The beams' superelements are the unstressed halves (``study.structures.beam_superelement``)."""

    dataset: str = "beams"
    models: tuple[str, ...] = ()
    n_levels: int = N_LEVELS

    def __post_init__(self):
        if self.dataset not in DATASETS:
            raise ValueError(f"field 'dataset' = {self.dataset!r}: expected one of {DATASETS}")
        unknown = [m for m in self.models if m not in DATASET_MODELS[self.dataset]]
        if unknown:
            raise ValueError(f"field 'models': {unknown} not available for dataset {self.dataset!r}; expected some "
                             f"of {DATASET_MODELS[self.dataset]}")
        if self.n_levels < 3:
            raise ValueError(f"field 'n_levels' = {self.n_levels}: expected at least 3")

    @property
    def friction_models(self) -> tuple[str, ...]:
        return self.models or DATASET_MODELS[self.dataset]


@dataclass(frozen=True)
class AcceptanceParameters:
    """[acceptance]: L-infinity bounds of paper section 4.4."""

    frequency_tolerance_hz: float = FREQUENCY_TOLERANCE_HZ
    damping_tolerance: float = DAMPING_TOLERANCE

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not value > 0.0:
                raise ValueError(f"field '{name}' = {value}: expected a positive bound")


@dataclass(frozen=True)
class ParetoParameters:
    """[pareto]: NSGA-II generations and population, seeded from the sample's front; representative
    designs per structure."""

    generations: int = 20
    population: int = 48
    representatives: int = 3

    def __post_init__(self):
        for name, value in asdict(self).items():
            if value < 1:
                raise ValueError(f"field '{name}' = {value}: expected at least 1")


def defaults() -> dict:
    return {"study": StudyParameters(), "sample": Sample(), "acceptance": AcceptanceParameters(),
            "pareto": ParetoParameters()}


@contextmanager
def cluster_client(scheduler: str | None):
    """A dask.distributed client: None (serial), ``local`` (a LocalCluster, one single-threaded worker process
    per core) or a scheduler address."""
    if not scheduler:
        yield None
        return
    from distributed import Client, LocalCluster

    if scheduler == "local":
        with LocalCluster(threads_per_worker=1, processes=True) as cluster, Client(cluster) as client:
            yield client
    else:
        with Client(scheduler) as client:
            yield client


def run(arguments: argparse.Namespace) -> None:
    """Run the chosen steps of the study."""
    parameters = configuration(arguments, defaults())
    with stage_folder(arguments.out):
        run_steps(arguments, parameters)


def run_steps(arguments: argparse.Namespace, parameters: dict) -> None:
    """The chosen steps, in order, into ``arguments.out`` (held by the caller)."""
    out = Path(arguments.out)
    workflow.check_dataset(out, parameters["study"].dataset)
    write_json(out / "study.json", {
        "configuration": {section: asdict(values) for section, values in parameters.items()},
        "seed": parameters["sample"].seed, "inputs": {"rom": str(arguments.rom), "data": str(arguments.data),
                                                     "reference": str(arguments.reference)},
        "versions": package_versions("numpy", "scipy", "numba", "pyarrow", "statsmodels", "pymoo", "dask")})
    paths = workflow.Paths(out, Path(arguments.rom), Path(arguments.data), Path(arguments.reference))
    for step in arguments.steps:
        if step == "measurements":
            workflow.measurements(paths, parameters)
        elif step == "explore":
            with cluster_client(arguments.scheduler) as client:
                workflow.explore_designs(paths, parameters, client, arguments.restart_stale)
        elif step == "analyse":
            workflow.analyse(paths, parameters)
        else:
            print(f"wrote {workflow.report(paths, parameters)}")


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
    command.add_argument("--steps", nargs="+", choices=STEPS, default=list(STEPS), help="steps to run, in order")
    command.add_argument("--scheduler", help="dask.distributed scheduler address, or 'local' for a LocalCluster "
                                             "(default: evaluate in this process)")
    command.add_argument("--restart-stale", action="store_true",
                         help="discard design chunks written for other inputs (a changed measurement, superelement "
                              "or sample) and recompute them, instead of refusing the folder")
    add_config_arguments(command, "[study], [sample], [acceptance], [pareto]", "sample.n_designs=20000")
    command.set_defaults(run=run)
