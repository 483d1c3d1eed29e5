"""``surrogacy fit --study FOLDER``: calibrate each friction model of a finished study on each of its structures
(global NSGA-II to a front that stops moving, least-squares polishes along it, the best compromise with its
uncertainty and a fitted zeta_0), seeded with the study's Pareto designs. Files: ``calibration.files``."""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from calibration.calibrate import MAX_GENERATIONS, calibrate
from calibration.files import calibration_record, plot_fits, read_calibration, write_fronts, write_markdown
from calibration.objectives import fit_space
from nonlinear.joint import parameter_limits, parameter_names, to_unit
from pipeline.cache import package_versions
from pipeline.files import sha256_file, sha256_json, stage_folder, write_json
from study.workflow import front_designs, read_study

VERSIONS = package_versions("numpy", "scipy", "numba", "pymoo")


def run(arguments: argparse.Namespace) -> None:
    """Calibrate the study's models on its structures; each (model, structure) once, skipped on a rerun."""
    paths, parameters, explored = read_study(arguments.study)
    models = arguments.models or list(explored.models)
    structures = arguments.structures or list(explored.names)
    unknown = [m for m in models if m not in explored.models] + [s for s in structures if s not in explored.names]
    if unknown:
        raise ValueError(f"{arguments.study}: {unknown} not in the study (models {list(explored.models)}, "
                         f"structures {list(explored.names)})")
    if arguments.max_generations < 1:
        raise ValueError(f"option --max-generations = {arguments.max_generations}: expected at least 1")
    case = "measured" if parameters["study"].dataset == "asb" else "BRB"
    chosen = [(model, explored.names.index(name)) for model in models for name in structures]
    fronts = {(model, index): front_designs(paths, model, explored.n_groups, explored.names[index])
              for model, index in chosen}  # every input read before the output folder is touched
    with stage_folder(arguments.out) as out:
        records = {model: [] for model in models}
        for model, index in tqdm(chosen, desc="calibrations", unit="fit"):
            structure = explored.structures[index]
            front = fronts[model, index]
            key = sha256_json({"fronts": sha256_file(paths.analysis / f"fronts_{model}.csv"),
                               "measurement": {"amplitude": structure.measurement.amplitude.tolist(),
                                               "frequency_hz": structure.measurement.frequency_hz.tolist(),
                                               "damping": structure.measurement.damping.tolist()},
                               "seed": arguments.seed, "max_generations": arguments.max_generations,
                               "versions": VERSIONS})
            path = out / model / f"{structure.name.replace(' ', '_')}.json"
            record = read_calibration(path, key)
            if record is None:
                result = calibrate(structure, model, explored.n_groups,
                                   to_unit(front.designs, *parameter_limits(model, explored.n_groups)),
                                   explored.damping_cases[case][index], arguments.seed + index,
                                   arguments.max_generations)
                sources = {"sample": front.errors[[label.startswith("sample") for label in front.labels]],
                           "nsga2": front.errors[[label.startswith("nsga2") for label in front.labels]]}
                record = calibration_record(result, key, {k: v for k, v in sources.items() if len(v)})
                path.parent.mkdir(parents=True, exist_ok=True)
                write_json(path, record)
            records[model].append(record)
        structure_of = dict(zip(explored.names, explored.structures))
        for model, chosen_records in records.items():
            names = parameter_names(model, explored.n_groups)
            write_fronts(out / f"front_{model}.csv", chosen_records, lambda record: fit_space(
                model, explored.n_groups, structure_of[record["structure"]].measurement))
            plot_fits(out / f"fits_{model}.png", model, [
                (structure_of[r["structure"]], ["best compromise"], [[r["best"]["parameters"][name] for name in names]],
                 r["best"]["parameters"]["zeta_0"]) for r in chosen_records])
        write_markdown(out / "calibration.md", [r for chosen_records in records.values() for r in chosen_records])
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
