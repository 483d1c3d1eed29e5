"""The steps of a study on files: measurements, exploration, analysis, report (``surrogacy study``).

Folder layout under the study's ``out``::

    study.json                       resolved configuration, seed, inputs, versions
    measurements/<structure>.csv     backbones to fit (experiment.backbone_files), virtual ones with
                                     <beam>_experiment.json beside them
    designs/exploration.json         study key, sample, structures and the mode chosen on each
    designs/<model>/chunk-<c>.parquet
    analysis/surrogacy_<model>.csv, .md, surrogacy_bounds_<model>.png, fronts_<model>.csv (sample and NSGA-II),
             pareto_<model>.png, responses_<model>.png, anova.csv, anova.md, prestress.md, prestress.png
    report.md
"""

from __future__ import annotations

import json
from functools import cache
from dataclasses import asdict
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
import pandas as pd

from nonlinear.compute_devices import DEVICES, check_device
from nonlinear.condensation import modal_split
from nonlinear.joint import from_unit, parameter_limits, parameter_names, to_unit
from pipeline.cache import is_current, package_versions, read_sidecar, sidecar_record
from pipeline.config import resolve
from pipeline import runners
from pipeline.files import atomic_path, sha256_file, write_json
from pipeline.runners import SERIAL
from pipeline.published import PaperTables, paper_tables
from study import anova, figures, pareto, prestress, surrogacy
from study.analysis import anova_observations, design_rows, representative_designs, sample_counts
from study.datasets import dataset, dataset_structures, measurement_path
from study.errors import design_errors
from study.exploration import Explored, Exploration, StudyError, check_explored, explore, refuse_other_studies
from study.parameters import defaults
from study.report import write_report
from reduction.superelement import StructureError


VERSIONS = package_versions("numpy", "scipy", "numba")
STEPS = ("measurements", "explore", "analyse", "report")


class Paths(NamedTuple):
    """The study's folder and its inputs: the beams' superelements, the ASB data, and a folder of the user's own
    paper tables that replace the project's (``pipeline.published.paper_tables``; None: the paper's)."""

    out: Path
    rom: Path
    data: Path
    reference: Path | None = None

    @property
    def tables(self) -> PaperTables:
        """The paper's tables, the user's from ``reference`` where it holds them."""
        return paper_tables(self.reference)

    @property
    def measurements(self) -> Path:
        return self.out / "measurements"

    @property
    def designs(self) -> Path:
        return self.out / "designs"

    @property
    def analysis(self) -> Path:
        return self.out / "analysis"


def recorded_datasets(out: Path) -> list[tuple[Path, str]]:
    """(file, dataset) of each file of a study folder that records its dataset: ``study.json`` and
    ``measurements/measurements.json``; none for a new folder."""
    recorded = []
    for path, keys in ((out / "study.json", ("configuration", "study", "dataset")),
                       (out / "measurements" / "measurements.json", ("inputs", "dataset"))):
        value = read_sidecar(path)
        for key in keys:
            value = value.get(key) if isinstance(value, dict) else None
        if isinstance(value, str):
            recorded.append((path, value))
    return recorded


def check_dataset(out: Path, dataset: str) -> None:
    """Refuse, before any step, a results folder that holds a study of another dataset: its measurements and
    designs would be mixed with this one's. Raises StudyError naming the file that records the other dataset."""
    for path, recorded in recorded_datasets(Path(out)):
        if recorded != dataset:
            raise StudyError(f"{path}: a study of the {recorded!r} dataset; expected {dataset!r} here (give the "
                             f"{dataset} study another --out)")


def measurements(paths: Paths, parameters: dict, before_writing: Callable[[], None]) -> None:
    """Write the dataset's backbones to fit (virtual experiments of the beams, or the ASB's measured ones),
    unless ``measurements/measurements.json`` records them for the same input files (then nothing is redone);
    ``before_writing`` is called once the input files are found, before the first file is written."""
    chosen = dataset(parameters["study"].dataset)
    sources = chosen.sources(paths)
    missing = [str(source) for source in sources if not source.exists()]
    if missing:
        raise StructureError(f"{', '.join(missing)}: missing (inputs of the {chosen.name} measurements)")
    inputs = {"dataset": chosen.name, "sources": {source.name: sha256_file(source) for source in sources},
              **chosen.inputs(paths)}
    sidecar = paths.measurements / "measurements.json"
    kinds = [measurement_path(paths.measurements, name).stem for name in chosen.structures]
    if is_current(sidecar, inputs, VERSIONS, kinds):
        print(f"measurements: {paths.measurements} is current")
        return
    before_writing()
    chosen.write_measurements(paths)
    files = {kind: paths.measurements / f"{kind}.csv" for kind in kinds}
    write_json(sidecar, sidecar_record(inputs, VERSIONS, files))


def exploration(paths: Paths, parameters: dict) -> Exploration:
    """The study's structures, models, sample and damping cases from the measurement files, and its compute
    device."""
    study = parameters["study"]
    chosen = dataset(study.dataset)
    structures = dataset_structures(chosen.name, paths, study.n_levels, study.prestress)
    return Exploration(tuple(structures), study.friction_models, parameters["sample"],
                       chosen.damping_cases(paths, structures), chosen.damping_rule, parameters["compute"].device)


class StudyFolder(NamedTuple):
    """A finished study as its readers need it: the folders, the resolved configuration and the exploration."""

    paths: Paths
    parameters: dict
    exploration: Exploration


def read_study(folder: Path, device: str | None = None) -> StudyFolder:
    """A study's folder (``surrogacy study`` output: study.json, measurements/): its configuration resolved and its
    structures rebuilt from the measurement files, and its exploration, where it has one, checked as the analyse
    step checks it (``check_explored``: made for these inputs, every chunk with the rows its seed regenerates)
    before any reader uses it: a measurement edited after the study, or a chunk copied, cut or removed, is
    refused, never read. device: the reader's compute device (``compute.device``; default the study's: the
    machine that reads a study need not be the one that explored it). Raises ValueError naming study.json where
    it is missing, StudyError naming the first file that differs."""
    folder = Path(folder)
    record_path = folder / "study.json"
    if not record_path.exists():
        raise ValueError(f"{record_path}: missing (not a study folder: run surrogacy study first)")
    record = json.loads(record_path.read_text())
    if device not in (None, *DEVICES):
        raise ValueError(f"device {device!r}: expected one of {DEVICES}")
    parameters = resolve(defaults(), record["configuration"], [("compute", "device", device)] if device else (),
                         source=str(record_path))
    inputs = record["inputs"]
    paths = Paths(folder, Path(inputs["rom"]), Path(inputs["data"]),
                  None if inputs.get("reference") is None else Path(inputs["reference"]))
    explored = exploration(paths, parameters)
    if (paths.designs / "exploration.json").exists():  # a study of its measurements only has no sample to check
        check_explored(explored, paths.designs)
    return StudyFolder(paths, parameters, explored)


def check_reader_device(folder: StudyFolder) -> None:
    """ValueError where the compute device a reader of a finished study evaluates on (``read_study``'s: the study's
    compute.device or the command's --device) cannot run in this process; for a command to call before it writes
    anything."""
    check_device(folder.exploration.device, "compute device (option --device, default: the study's compute.device)")


class FrontDesigns(NamedTuple):
    """A structure's Pareto designs in a finished study: designs (k, d) in physical units, a label each ("sample
    <design>" or "nsga2 <i>"), and their errors (k, 2) (e_f Hz, e_zeta -) as the study computed them."""

    designs: np.ndarray
    labels: list[str]
    errors: np.ndarray


def front_designs(paths: Paths, model: str, n_groups: int, structure: str) -> FrontDesigns:
    """The designs of ``analysis/fronts_<model>.csv`` for ``structure``: the sample's front (parameters read back
    from the exploration's chunks) and NSGA-II's. Raises ValueError where the analyse step has not run."""
    fronts_path = paths.analysis / f"fronts_{model}.csv"
    if not fronts_path.exists():
        raise ValueError(f"{fronts_path}: missing (run the study's analyse step first)")
    fronts = pd.read_csv(fronts_path)
    fronts = fronts[fronts["structure"] == structure]
    names = parameter_names(model, n_groups)
    sample = fronts[fronts["source"] == "sample"]
    designs = np.vstack([design_rows(paths.designs, model, sample["design"].to_numpy(), names),
                         fronts.loc[fronts["source"] == "nsga2", names].to_numpy()])
    labels = [f"sample {d}" for d in sample["design"]] + [f"nsga2 {i}" for i in range(len(designs) - len(sample))]
    errors = np.vstack([sample[["frequency_error_hz", "damping_error"]].to_numpy(),
                        fronts.loc[fronts["source"] == "nsga2", ["frequency_error_hz", "damping_error"]].to_numpy()])
    return FrontDesigns(designs, labels, errors)


def explore_designs(paths: Paths, parameters: dict, before_writing: Callable[[], None], runner=SERIAL,
                    restart_stale: bool = False) -> Explored:
    """Evaluate every design chunk not yet written (``study.exploration.explore``). Unless ``restart_stale``, a
    designs folder holding another study's chunks is refused (StudyError) before ``before_writing`` is called and
    any file written."""
    explored = exploration(paths, parameters)
    if not restart_stale:
        refuse_other_studies(explored, paths.designs)
    before_writing()
    return explore(explored, paths.designs, runner, restart_stale=restart_stale)


def analyse(paths: Paths, parameters: dict, before_writing: Callable[[], None]) -> None:
    """Surrogacy matrices, bounds sensitivity, fronts (sample and NSGA-II), responses, ANOVA, prestress. Refused
    (StudyError), before ``before_writing`` is called and any file written, unless the designs folder holds the
    whole exploration of the current inputs, each chunk the designs its seed regenerates
    (``study.exploration.check_explored``). Each model's chunks are read once (``study.analysis.sample_counts``):
    memory bounded by a chunk and the counts, whatever the number of designs."""
    study, acceptance = parameters["study"], parameters["acceptance"]
    explored = exploration(paths, parameters)
    check_explored(explored, paths.designs)
    before_writing()
    names = explored.names
    chosen = dataset(study.dataset)
    case = chosen.default_damping_case
    out = paths.analysis
    paper = surrogacy.paper_surrogacy(paths.tables.table5) if chosen.paper else None
    sweep_frequency = acceptance.frequency_tolerance_hz * np.array([0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0])
    sweep_damping = acceptance.damping_tolerance * np.array([0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0])
    counts = {}
    for model in explored.models:
        sample = counts[model] = sample_counts(paths.designs, model, names, list(explored.damping_cases), case,
                                               acceptance.frequency_tolerance_hz, acceptance.damping_tolerance,
                                               sweep_frequency, sweep_damping)
        matrix = surrogacy.matrix_from_counts(sample.joint_counts)
        table = surrogacy.surrogacy_table({model: matrix}, names, paper)
        spread = surrogacy.replicate_from_counts(sample.replicate_labels, sample.replicate_joint_counts[case])
        table["replicate_mean"] = spread.mean.ravel()
        table["replicate_standard_deviation"] = spread.standard_deviation.ravel()
        surrogacy.write_surrogacy_csv(table, out / f"surrogacy_{model}.csv")
        surrogacy.write_surrogacy_markdown(table, out / f"surrogacy_{model}.md")
        sweep = surrogacy.matrix_from_counts(sample.bounds_joint_counts)
        surrogacy.plot_bounds_sensitivity(sweep, sweep_frequency, sweep_damping, names,
                                          out / f"surrogacy_bounds_{model}.png", acceptance.frequency_tolerance_hz,
                                          acceptance.damping_tolerance, title=model)
        fronts = pareto_fronts(paths, parameters, explored, model, sample.fronts, sample.n_designs)
        figures.plot_fronts(out / f"pareto_{model}.png", model, names, sample.plotted, sample.n_designs, fronts,
                            acceptance)
        responses(paths, parameters, explored, model, fronts)
    if chosen.paper:
        observations = anova_observations(counts, names)
        table = anova.surrogacy_anova(observations)
        anova.write_anova_markdown(table, out / "anova.md", anova.paper_anova(paths.tables.table6),
                                   int(observations["confidence"].isna().sum()))
        with atomic_path(out / "anova.csv") as temporary:
            table.to_csv(temporary, index=False)
        if prestress.MODEL in explored.models:
            sbrb = explored.structures[names.index(prestress.BEAM)]
            designs = design_rows(paths.designs, prestress.MODEL,
                                  np.arange(min(prestress.DESIGNS, explored.sample.n_designs)),
                                  parameter_names(prestress.MODEL, explored.n_groups))
            comparison = prestress.compare(paths.rom / f"{prestress.BEAM}.npz", designs,
                                           sbrb.measurement.low_amplitude_frequency_hz)
            prestress.write_comparison(comparison, out / "prestress.md", out / "prestress.png")


class Fronts(NamedTuple):
    """Per structure: the sample's front and NSGA-II's front (unit designs (k, d) and errors (k, 2))."""

    sample: list
    nsga2_errors: list
    nsga2_designs: list


def pareto_fronts(paths: Paths, parameters: dict, explored: Exploration, model: str, sample_fronts: list,
                  n_designs: int) -> Fronts:
    """NSGA-II on each structure seeded from the sample's front there (``study.analysis.Front``, one per
    structure) and ``population`` designs drawn from the sample's n_designs (paper Fig. 6), both fronts written to
    fronts_<model>.csv (the column source: "sample" or "nsga2")."""
    settings, case = parameters["pareto"], dataset(parameters["study"].dataset).default_damping_case
    limits = parameter_limits(model, explored.n_groups)
    names = parameter_names(model, explored.n_groups)
    nsga_errors, nsga_designs, rows = [], [], []
    for index, (structure, front) in enumerate(zip(explored.structures, sample_fronts)):
        zeta0 = explored.damping_cases[case][index]
        split = modal_split(structure.space)

        def objective(unit, structure=structure, zeta0=zeta0, split=split):
            result = design_errors(structure, model, from_unit(unit, *limits), [zeta0], split=split,
                                   rule=explored.damping_rule, device=explored.device)
            return np.column_stack([result.frequency_error_hz, result.damping_error[:, 0]])

        rng = np.random.default_rng([parameters["sample"].seed, index])
        drawn = (rng.choice(n_designs, settings.population, replace=False) if n_designs > settings.population
                 else np.arange(n_designs))
        seeds = to_unit(design_rows(paths.designs, model, front.design, names), *limits)
        extra = to_unit(design_rows(paths.designs, model, drawn, names), *limits)
        result = pareto.nsga2_front(objective, np.vstack([seeds, extra]), generations=settings.generations,
                                    population=settings.population, seed=parameters["sample"].seed + index)
        designs, values = result.designs, result.errors
        nsga_errors.append(values)
        nsga_designs.append(designs)
        rows += [{"structure": structure.name, "source": "sample", "design": int(d), "frequency_error_hz": f,
                  "damping_error": z} for d, f, z in zip(*front)]
        rows += [{"structure": structure.name, "source": "nsga2", "design": -1, "frequency_error_hz": f,
                  "damping_error": z, **dict(zip(names, from_unit(u, *limits)))} for u, (f, z) in zip(designs, values)]
    with atomic_path(paths.analysis / f"fronts_{model}.csv") as temporary:
        pd.DataFrame(rows).to_csv(temporary, index=False)
    return Fronts(list(sample_fronts), nsga_errors, nsga_designs)


def responses(paths: Paths, parameters: dict, explored: Exploration, model: str, fronts: Fronts) -> None:
    """Backbones of representative front designs of each structure against its measurement (Figs. 9-11)."""
    acceptance, case = parameters["acceptance"], dataset(parameters["study"].dataset).default_damping_case
    names = parameter_names(model, explored.n_groups)
    curves = []
    for index, structure in enumerate(explored.structures):
        front = fronts.sample[index]
        chosen = representative_designs(front, acceptance.frequency_tolerance_hz, acceptance.damping_tolerance,
                                        parameters["pareto"].representatives)
        designs = design_rows(paths.designs, model, front.design[chosen], names)
        curves.append((structure, front.design[chosen], designs, explored.damping_cases[case][index]))
    figures.plot_responses(paths.analysis / f"responses_{model}.png", model, curves, rule=explored.damping_rule,
                           device=explored.device)


def report(paths: Paths, parameters: dict) -> Path:
    """Assemble report.md from the analysis folder."""
    return write_report(paths, parameters)


def write_study_record(paths: Paths, parameters: dict) -> None:
    """``study.json``: the resolved configuration, seed, inputs and versions of the study in ``paths.out``."""
    write_json(paths.out / "study.json", {
        "configuration": {section: asdict(values) for section, values in parameters.items()},
        "seed": parameters["sample"].seed, "inputs": {"rom": str(paths.rom), "data": str(paths.data),
                                                     "reference": None if paths.reference is None
                                                     else str(paths.reference)},
        "versions": package_versions("numpy", "scipy", "numba", "pyarrow", "statsmodels", "pymoo", "dask")})


def run_steps(paths: Paths, parameters: dict, steps, scheduler: str | None = None, restart_stale: bool = False):
    """The chosen ``steps`` of ``STEPS``, in order, into ``paths.out`` (held by the caller). study.json
    (``write_study_record``) is written once, by the first step that writes a file, after that step checked its
    inputs: a run refused by a check (a folder of another dataset, chunks of another study, an exploration of other
    inputs) changes no file. Yields (step, its result): the run (``study.exploration.Explored``) for ``explore``,
    the report's path for ``report``, None otherwise."""
    check_dataset(paths.out, parameters["study"].dataset)
    record = cache(lambda: write_study_record(paths, parameters))
    for step in steps:
        if step == "measurements":
            yield step, measurements(paths, parameters, record)
        elif step == "explore":
            with runners.runner(scheduler) as runner:
                yield step, explore_designs(paths, parameters, record, runner, restart_stale)
        elif step == "analyse":
            yield step, analyse(paths, parameters, record)
        else:
            record()
            yield step, report(paths, parameters)
