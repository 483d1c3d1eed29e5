"""The calibration stage on files: a finished study's folder in, ``calibration.files``'s folder out; each
(model, structure) calibrated once and written at once, so that an interrupted run resumes where it stopped and a
rerun with the same inputs repeats nothing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from calibration.bounds import bounds_table, write_bounds
from calibration.calibrate import MAX_GENERATIONS, METHOD, calibrate, chi_squared
from calibration.files import (calibration_record, plot_fits, read_calibration, spread_table, write_fronts,
                               write_markdown, write_spread)
from calibration.objectives import backbone_solver, fit_space
from nonlinear.friction_models import MODEL_NAMES, friction_model
from nonlinear.joint import contained_unit_designs, parameter_limits, parameter_names, to_unit
from pipeline.cache import package_versions
from pipeline.files import sha256_file, sha256_json, stage_folder, write_json
from study.datasets import dataset
from study.exploration import Exploration, structure_errors
from study.structures import Structure
from study.workflow import Paths, check_reader_device, front_designs, read_study

VERSIONS = package_versions("numpy", "scipy", "numba", "pymoo")


def calibration_key(paths: Paths, model: str, structure: Structure, seed: int, max_generations: int,
                    fitted_seeds) -> str:
    """What a calibration's result depends on: the study's fronts file, the measurement's levels, the seed, the
    generation cap, the seeds from the contained model's calibration, the method's settings
    (``calibration.calibrate.METHOD``) and the versions (SHA-256 of their JSON)."""
    measurement = structure.measurement
    return sha256_json({"fronts": sha256_file(paths.analysis / f"fronts_{model}.csv"),
                        "measurement": {"amplitude": measurement.amplitude.tolist(),
                                        "frequency_hz": measurement.frequency_hz.tolist(),
                                        "damping": measurement.damping.tolist()},
                        "seed": seed, "max_generations": max_generations, "method": METHOD, "versions": VERSIONS,
                        "fitted_seeds": np.asarray(fitted_seeds).tolist()})


def contained_seeds(model: str, n_groups: int, measurement, record: dict | None) -> np.ndarray:
    """The calibrated front and best compromise of the model ``model`` contains (its record on the structure that
    made ``measurement``, or None where it was not calibrated in this run), as points (k, d + 1) of ``model``'s fit
    box: the added parameters at ``nonlinear.friction_models.CONTAINED_UNIT``, zeta_0 kept
    (``nonlinear.joint.contained_unit_designs``)."""
    if record is None:
        return np.empty((0, len(parameter_names(model, n_groups)) + 1))
    inner = fit_space(friction_model(model).contains, n_groups, measurement)
    best = to_unit(np.array([[record["best"]["parameters"][name] for name in inner.names]]), inner.lower,
                   inner.upper, inner.logarithmic)
    points = np.vstack([np.array(record["front"]["unit"]), best])
    return np.column_stack([contained_unit_designs(points[:, :-1], model, n_groups), points[:, -1]])


def study_errors(explored: Exploration, case: str, record: dict) -> tuple[float, float]:
    """The L-infinity errors (e_f Hz, e_zeta -) of a calibration record's best compromise as the study evaluates a
    design: its joint parameters with the study's zeta_0 for ``case`` and its damping rule
    (``study.exploration.structure_errors``). Raises ValueError where that evaluation does not converge."""
    index = explored.names.index(record["structure"])
    design = np.array([[record["best"]["parameters"][name] for name in parameter_names(record["model"],
                                                                                       explored.n_groups)]])
    errors = structure_errors(explored, record["model"], design, structures=[index])[0]
    if not errors.converged[0]:
        raise ValueError(f"the best compromise of {record['model']} on {record['structure']}: not converged as the "
                         f"study evaluates it ({errors.reason[0]})")
    return float(errors.frequency_error_hz[0]), float(errors.damping_error[0, list(explored.damping_cases).index(case)])


FRONTS_ERRORS = ("frequency_error_hz", "damping_error")


def check_fronts(path: Path, model: str, n_groups: int, structures: list[str], n_designs: int) -> None:
    """Refuse a study's ``analysis/fronts_<model>.csv`` (docs/formats.md) that ``study.workflow.front_designs``
    could not read as the analyse step wrote it, naming the file, the line (the header is line 1), the column and
    what was expected: a file that is not CSV text, a missing column, a ``source`` other than sample or nsga2, a
    sample ``design`` that is not an index of the study's n_designs, an error or an NSGA-II parameter that is not a
    finite number (a cut line leaves it empty), or no row for one of ``structures``. Missing: ValueError as there."""
    if not path.exists():
        raise ValueError(f"{path}: missing (run the study's analyse step first)")
    names = parameter_names(model, n_groups)
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError) as error:  # pandas' parser errors and a UnicodeDecodeError are ValueErrors
        raise ValueError(f"{path}: not a readable fronts CSV ({error}); expected the study's analyse step's file") \
            from None
    missing = [column for column in ("structure", "source", "design", *FRONTS_ERRORS, *names)
               if column not in table]
    if missing:
        raise ValueError(f"{path}: column {missing[0]!r}: missing; expected the columns structure, source, design, "
                         f"{', '.join(FRONTS_ERRORS)}, {', '.join(names)}")

    def refuse(row: int, column: str, expected: str):
        value = table.at[row, column]  # a cell a cut line lacks: NaN
        shown = repr(value) if isinstance(value, str) and value else "empty"
        raise ValueError(f"{path}: line {row + 2}, column {column!r}: {shown}; expected {expected}")

    def numbers(column: str, rows) -> np.ndarray:
        values = pd.to_numeric(table.loc[rows, column], errors="coerce").to_numpy(float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            refuse(int(np.asarray(rows)[bad[0]]), column, "a finite number")
        return values

    other = np.flatnonzero(~table["source"].isin(["sample", "nsga2"]))
    if other.size:
        refuse(int(other[0]), "source", "sample or nsga2")
    every = table.index.to_numpy()
    for column in FRONTS_ERRORS:
        negative = np.flatnonzero(numbers(column, every) < 0)
        if negative.size:
            refuse(int(every[negative[0]]), column, "an error of at least 0")
    sample = table.index[table["source"] == "sample"].to_numpy()
    designs = numbers("design", sample)
    wrong = np.flatnonzero((designs != np.round(designs)) | (designs < 0) | (designs >= n_designs))
    if wrong.size:
        refuse(int(sample[wrong[0]]), "design", f"an index of the study's sample, 0 to {n_designs - 1}")
    nsga2 = table.index[table["source"] == "nsga2"].to_numpy()
    for name in names:
        numbers(name, nsga2)
    absent = [name for name in structures if not (table["structure"] == name).any()]
    if absent:
        raise ValueError(f"{path}: column 'structure': no row for {absent[0]!r}; expected the sample's and NSGA-II's "
                         "front of every structure the study analysed")


def nested_row(record: dict, contained: dict, structure: Structure, n_groups: int, device: str = "cpu") -> dict:
    """A model's best compromise against that of the model it contains (``FrictionModel.contains``) on one
    structure: both chi^2, the chi^2 of the contained optimum mapped into the model's box (``contained_seeds``;
    it differs from the contained chi^2 by what the containment leaves: iwan4_core's weakest core, iwan4's
    Jenkins limit), and ``holds``: the model's chi^2 is at most the higher of the two (1e-9 relative; the
    calibration polishes from the mapped optimum, so it reaches at most that). A model that does not hold is a
    defect of the calibration: it missed an optimum it contains. device: where the mapped optimum is solved."""
    mapped = contained_seeds(record["model"], n_groups, structure.measurement, contained)[-1:]
    space = fit_space(record["model"], n_groups, structure.measurement)
    at_contained = float(chi_squared(structure, space, mapped, backbone_solver(structure, device))[0])
    model_chi, contained_chi = record["best"]["chi_squared"], contained["best"]["chi_squared"]
    return {"model": record["model"], "contains": contained["model"], "structure": structure.name,
            "chi_squared": model_chi, "contained_chi_squared": contained_chi,
            "mapped_chi_squared": at_contained,
            "holds": bool(model_chi <= max(contained_chi, at_contained) * (1.0 + 1e-9))}


def calibrate_study(study: Path, out: Path, models=None, structures=None, seed: int = 0,
                    max_generations: int = MAX_GENERATIONS, device: str | None = None, replicates=()
                    ) -> tuple[Path, list[str]]:
    """Calibrate ``models`` (default: the study's; in the registry's order) on ``structures`` (default: the
    study's) of the study in ``study``, seeded with its Pareto designs and its zeta_0, and a model that contains
    another one calibrated here (``FrictionModel.contains``) also with that one's calibrated front; write ``out``
    (``calibration.files``) and return it with the nested models' defects (``nested_row``), one line each.
    replicates: study seed -> folder of a calibration (``calibrate_replicates``) of a study of the same inputs at
    that seed: the spread of each best compromise's chi^2 over them and this one is written (``spread.csv``,
    ``calibration.md``). device: where the calibrations are solved (``nonlinear.compute_devices``; default the
    study's ``compute.device``).
    Raises ValueError for an unknown model, a model or structure the study does not hold, a cap below one, a
    device that cannot run here (``study.workflow.check_reader_device``), or a study without its analysis or with a
    fronts file that cannot be read (``check_fronts``), before the output folder is touched. A record whose key
    matches but which lacks a field this run reads is calibrated again (``calibration.files.read_calibration``)."""
    unknown = [model for model in models or () if model not in MODEL_NAMES]
    if unknown:
        raise ValueError(f"option --models: {unknown[0]!r}: not a friction model; expected some of "
                         f"{list(MODEL_NAMES)}")
    folder = read_study(study, device)
    check_reader_device(folder)
    paths, parameters, explored = folder
    models = sorted(models or explored.models, key=MODEL_NAMES.index)  # a contained model before its container
    structures = list(structures or explored.names)
    unknown = [m for m in models if m not in explored.models] + [s for s in structures if s not in explored.names]
    if unknown:
        raise ValueError(f"{study}: {unknown} not in the study (models {list(explored.models)}, "
                         f"structures {list(explored.names)})")
    if max_generations < 1:
        raise ValueError(f"option --max-generations = {max_generations}: expected at least 1")
    case = dataset(parameters["study"].dataset).default_damping_case  # the study's zeta_0, paired with its seeds
    chosen = [(model, explored.names.index(name)) for model in models for name in structures]
    for model in models:
        check_fronts(paths.analysis / f"fronts_{model}.csv", model, explored.n_groups, structures,
                     explored.sample.n_designs)
    fronts = {(model, index): front_designs(paths, model, explored.n_groups, explored.names[index])
              for model, index in chosen}  # every input read before the output folder is touched
    with stage_folder(out) as out:
        records, calibrated = {model: [] for model in models}, {}
        for model, index in tqdm(chosen, desc="calibrations", unit="fit"):
            structure, front = explored.structures[index], fronts[model, index]
            contained = friction_model(model).contains
            fitted = contained_seeds(model, explored.n_groups, structure.measurement,
                                     calibrated.get((contained, index)) if contained else None)
            key = calibration_key(paths, model, structure, seed, max_generations, fitted)
            path = out / model / f"{structure.name.replace(' ', '_')}.json"
            record = read_calibration(path, key, model, structure.name,
                                      fit_space(model, explored.n_groups, structure.measurement).names)
            if record is None:
                result = calibrate(structure, model, explored.n_groups,
                                   to_unit(front.designs, *parameter_limits(model, explored.n_groups)),
                                   explored.damping_cases[case][index], seed + index, max_generations, fitted,
                                   explored.damping_rule, explored.device)
                sources = {name: front.errors[[label.startswith(name) for label in front.labels]]
                           for name in ("sample", "nsga2")}
                record = calibration_record(result, key, {k: v for k, v in sources.items() if len(v)})
                path.parent.mkdir(parents=True, exist_ok=True)
                write_json(path, record)
            records[model].append(record)
            calibrated[model, index] = record
        structure_of = dict(zip(explored.names, explored.structures))
        for model, model_records in records.items():
            names = parameter_names(model, explored.n_groups)
            write_fronts(out / f"front_{model}.csv", model_records, lambda record: fit_space(
                model, explored.n_groups, structure_of[record["structure"]].measurement))
            plot_fits(out / f"fits_{model}.png", model, [
                (structure_of[r["structure"]], ["best compromise"], [[r["best"]["parameters"][n] for n in names]],
                 r["best"]["parameters"]["zeta_0"]) for r in model_records], explored.device)
        every = [r for model_records in records.values() for r in model_records]
        bounds = bounds_table(every, [study_errors(explored, case, record) for record in every],
                              {name: s.measurement for name, s in structure_of.items()}, case)
        write_bounds(bounds, out / "bounds.csv")
        nested = [nested_row(record, calibrated[contained, index], explored.structures[index], explored.n_groups,
                             explored.device)
                  for (model, index), record in calibrated.items()
                  if (contained := friction_model(model).contains) and (contained, index) in calibrated]
        spread = None
        if replicates:
            spread = spread_table({parameters["sample"].seed: every,
                                   **{seed: replicate_records(folder, every) for seed, folder in replicates.items()}})
            write_spread(spread, out / "spread.csv")
        write_markdown(out / "calibration.md", every, bounds, nested, spread)
    defects = [f"{row['model']} on {row['structure']}: best compromise chi^2 {row['chi_squared']:.6g} above "
               f"{row['contains']}'s {row['contained_chi_squared']:.6g}, which it contains (a defect of the "
               "calibration)" for row in nested if not row["holds"]]
    return out, defects


def replicate_records(folder: Path, records: list[dict]) -> list[dict]:
    """The records of a replicate calibration in ``folder`` of the same models and structures as ``records``.
    Raises ValueError naming a missing one."""
    def read(record):
        path = folder / record["model"] / f"{record['structure'].replace(' ', '_')}.json"
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError):
            raise ValueError(f"{path}: missing or unreadable; expected the replicate's calibration of "
                             f"{record['model']} on {record['structure']}") from None
    return [read(record) for record in records]


def calibrate_replicates(studies, primary: Path, out: Path, models=None, structures=None, seed: int = 0,
                         max_generations: int = MAX_GENERATIONS, device: str | None = None
                         ) -> tuple[dict[int, Path], list[str]]:
    """Calibrate each study folder of ``studies`` (the inputs of the study ``primary`` at other sample seeds) as
    ``calibrate_study`` does, into ``out``/replicates/seed-<its seed>; returns study seed -> folder and their
    defects, each line prefixed with the seed. Raises ValueError, before any calibration, for a study of the
    primary's seed or of another replicate's."""
    if not studies:
        return {}, []
    seeds = {read_study(primary)[1]["sample"].seed: primary}
    for study in studies:
        study_seed = read_study(study)[1]["sample"].seed
        if study_seed in seeds:
            raise ValueError(f"option --replicates: {study}: seed {study_seed}, the seed of {seeds[study_seed]}; "
                             "expected studies of seeds distinct from each other and from --study's")
        seeds[study_seed] = study
    folders, defects = {}, []
    for study_seed, study in list(seeds.items())[1:]:
        folders[study_seed], found = calibrate_study(study, out / "replicates" / f"seed-{study_seed}", models,
                                                     structures, seed, max_generations, device)
        defects += [f"seed {study_seed}: {line}" for line in found]
    return folders, defects
