"""The calibration stage's files (``surrogacy fit``), written to its output folder:

    <model>/<structure>.json   one calibration (``calibration.calibrate``): its inputs' key, the best compromise
                               (parameters with uncertainty, zeta_0, chi^2, plain errors, undetermined parameters),
                               the global phase's cost, the calibrated front and the study's fronts' best points
                               and hypervolumes; written once, so that a rerun skips what is finished
    front_<model>.csv          every structure's calibrated front (the non-dominated set of every design the
                               calibration evaluated) and its best compromise: structure, source (the phase that
                               evaluated the design: global, polished w=..., multistart, best compromise; the
                               best compromise's own row last), the design's parameters (N, N/m, -), zeta_0,
                               frequency_error_hz, damping_error
    spread.csv                 with replicate studies (other seeds): per model, structure and study seed the best
                               compromise's chi^2, reduced chi^2 and convergence, and the spread of the reduced
                               chi^2 over the seeds, (max - min) / min
    fits_<model>.png           the measurement and the best compromise's backbone, per structure
    bounds.csv                 acceptance bounds from the data per model and structure (``calibration.bounds``)
    calibration.md             the tables of every model and structure

Hypervolume. Both fronts of a structure (the study's sample and NSGA-II fronts together, and the calibrated one)
are measured in errors divided by a common reference point, 1.1 times the largest error of either front in each
objective; the hypervolume (pymoo's ``HV``) is then a fraction of the unit square, larger is better.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from pymoo.indicators.hv import HV

from calibration.bounds import MULTIPLE, NOISE_MULTIPLE
from calibration.calibrate import Calibration
from calibration.objectives import physical
from pipeline.files import atomic_path, json_float
from study import figures


def hypervolumes(study_errors: np.ndarray, calibrated_errors: np.ndarray) -> tuple[float, float]:
    """Hypervolumes of the study's and the calibrated front (errors (k, 2) each) at their common reference point
    (module docstring)."""
    reference = 1.1 * np.nanmax(np.vstack([study_errors, calibrated_errors]), axis=0)
    indicator = HV(ref_point=np.ones(2))
    return tuple(float(indicator(np.asarray(errors) / reference)) for errors in (study_errors, calibrated_errors))


def calibration_record(calibration: Calibration, key: str, study_front: dict) -> dict:
    """The JSON record of one calibration; study_front: "sample" and "nsga2" -> errors (k, 2) of the study."""
    space, best = calibration.space, calibration.best
    study_errors = np.vstack(list(study_front.values()))
    study_hv, calibrated_hv = hypervolumes(study_errors, calibration.front_errors)
    uncertainty = calibration.best_uncertainty
    values = [*best.design.tolist(), best.zeta0]
    return {
        "key": key, "structure": calibration.structure, "model": space.model,
        "best": {"parameters": dict(zip(space.names, values)),
                 "uncertainty": {name: {"value": None if np.isnan(value) else float(value), "kind": kind}
                                 for name, value, kind in zip(space.names, uncertainty.physical, uncertainty.kind)},
                 "undetermined": list(uncertainty.undetermined), "chi_squared": best.chi_squared,
                 "reduced_chi_squared": uncertainty.reduced_chi_squared, "converged": best.converged,
                 "message": best.message, "evaluations": best.evaluations, "restarts": best.restarts,
                 "errors": calibration.best_errors},
        "local_fits": {"count": len(calibration.fits), "converged": sum(fit.converged for fit in calibration.fits),
                       "evaluations": sum(fit.evaluations for fit in calibration.fits)},
        "global": {"evaluations": calibration.global_evaluations, "generations": calibration.global_generations},
        "front": {"unit": calibration.front_unit.tolist(), "errors": calibration.front_errors.tolist(),
                  "source": list(calibration.front_source)},
        "study": {name: {"frequency_error_hz": float(np.nanmin(errors[:, 0])),
                         "damping_error": float(np.nanmin(errors[:, 1]))} for name, errors in study_front.items()},
        "hypervolume": {"study": study_hv, "calibrated": calibrated_hv},
    }


BEST_ERRORS = ("frequency_max_relative", "damping_max_relative", "frequency_linf_hz", "damping_linf")


def record_problem(record, model: str, structure: str, names) -> str | None:
    """The first field of a calibration record that this stage reads and the record lacks or holds wrongly, as
    "field 'best.parameters.zeta_0': ..." (``calibration_record``'s layout; ``names``: the fit space's parameters
    with zeta_0), or None where the record is whole."""
    def field(path: str, expected: type):
        value = record
        for part in path.split("."):
            if not isinstance(value, dict) or part not in value:
                raise LookupError(f"field {path!r}: missing")
            value = value[part]
        if not isinstance(value, expected) or isinstance(value, bool):
            raise LookupError(f"field {path!r}: {value!r}; expected {getattr(expected, '__name__', 'a number')}")
        return value

    number, nullable = (int, float), (int, float, type(None))  # null: a number that was not finite
    try:
        for path, expected in (("model", str), ("structure", str), ("best.undetermined", list),
                               ("global.generations", int), ("hypervolume.study", nullable),
                               ("hypervolume.calibrated", nullable), ("study", dict)):
            field(path, expected)
        if (record["model"], record["structure"]) != (model, structure):
            return f"fields 'model', 'structure': {record['model']!r}, {record['structure']!r}; expected {model!r}, " \
                   f"{structure!r}"
        field("best.message", str)
        if not isinstance(record["best"].get("converged"), bool):
            return f"field 'best.converged': {record['best'].get('converged')!r}; expected true or false"
        for name in names:
            if not np.isfinite(field(f"best.parameters.{name}", number)):
                return f"field 'best.parameters.{name}': expected a finite number"
        for name in (*(f"errors.{error}" for error in BEST_ERRORS), "reduced_chi_squared"):
            field(f"best.{name}", nullable)
        lengths = {len(field(f"front.{part}", list)) for part in ("unit", "errors", "source")}
        if len(lengths) != 1 or 0 in lengths:
            return "fields 'front.unit', 'front.errors', 'front.source': expected lists of one equal, nonzero length"
    except LookupError as error:
        return str(error)
    return None


def read_calibration(path: Path, key: str, model: str, structure: str, names) -> dict | None:
    """The record at ``path`` if it holds ``key`` (the same inputs) and every field this stage reads
    (``record_problem``), else None: missing, unreadable, stale or damaged, it is calibrated again."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("key") != key:
        return None
    return None if record_problem(record, model, structure, names) else record


def write_fronts(path: Path, records: list[dict], space_of) -> None:
    """front_<model>.csv of the model's records: each structure's front, then its best compromise (source "best
    compromise", its L-infinity errors); space_of(record) -> its FitSpace."""
    rows = []
    for record in records:
        space = space_of(record)
        designs, zeta0 = physical(space, np.array(record["front"]["unit"]))
        for design, z, (f, d), source in zip(designs, zeta0, record["front"]["errors"], record["front"]["source"]):
            rows.append({"structure": record["structure"], "source": source, **dict(zip(space.names, [*design, z])),
                         "frequency_error_hz": f, "damping_error": d})
        best = record["best"]
        rows.append({"structure": record["structure"], "source": "best compromise",
                     **{name: best["parameters"][name] for name in space.names},
                     "frequency_error_hz": best["errors"]["frequency_linf_hz"],
                     "damping_error": best["errors"]["damping_linf"]})
    with atomic_path(path) as temporary:
        pd.DataFrame(rows).to_csv(temporary, index=False)


SPREAD_COLUMNS = ("model", "structure", "seed", "chi_squared", "reduced_chi_squared", "converged", "spread")


def spread_table(records_by_seed: dict) -> pd.DataFrame:
    """spread.csv (``SPREAD_COLUMNS``): records_by_seed, study seed -> the records of its calibration (the same
    models and structures, in the same order); spread: (max - min) / min of the reduced chi^2 over the seeds."""
    table = pd.DataFrame([{"model": record["model"], "structure": record["structure"], "seed": seed,
                           "chi_squared": record["best"]["chi_squared"],
                           "reduced_chi_squared": json_float(record["best"]["reduced_chi_squared"]),
                           "converged": bool(record["best"]["converged"])}
                          for seed, records in records_by_seed.items() for record in records])
    reduced = table.groupby(["model", "structure"], sort=False)["reduced_chi_squared"]
    table["spread"] = reduced.transform("max") / reduced.transform("min") - 1.0
    return table[list(SPREAD_COLUMNS)]


def write_spread(table: pd.DataFrame, destination: Path) -> None:
    """spread.csv (full precision), atomically."""
    with atomic_path(destination) as temporary:
        table.to_csv(temporary, index=False)


def plot_fits(path: Path, model: str, curves: list, device: str = "cpu") -> None:
    """fits_<model>.png: per structure the measurement and the best compromise (``study.figures.plot_responses``,
    solved on ``device``; curves: (Structure, labels, designs (1, d), zeta_0))."""
    figures.plot_responses(path, model, curves, f"{model}: the calibration's best compromise against the measurement",
                           device=device)


def markdown(records: list[dict], bounds: pd.DataFrame, nested=(), spread: pd.DataFrame | None = None) -> str:
    """calibration.md: one table row per model and structure (with the best compromise's convergence), the
    nested models against the models they contain (``nested``: ``calibration.workflow.nested_row``), the spread
    over study seeds where there is one (``spread_table``), then the acceptance bounds from the data
    (``calibration.bounds``). records: as ``calibration_record`` makes them or read back from their JSON (an error
    that is not a number, null there, as NaN)."""
    lines = ["# Calibration (surrogacy fit)", "",
             "Best L-infinity errors of the study's fronts (sample and NSGA-II) and of the calibrated front, their "
             "hypervolumes at a common reference point (larger is better), and the best compromise (least squares "
             "of frequency and damping at equal weight) with its fitted zeta_0 and the parameters the data leave "
             "undetermined.", "",
             "| model | structure | study e_f (Hz) | calibrated e_f (Hz) | study e_zeta | calibrated e_zeta | "
             "HV study | HV calibrated | best: max rel. f | best: max rel. zeta | zeta_0 | reduced chi^2 | "
             "undetermined | global generations | converged |", "|---" * 15 + "|"]
    for record in records:
        study = record["study"]
        front = np.array(record["front"]["errors"], dtype=float)
        best = record["best"]
        lines.append(
            f"| {record['model']} | {record['structure']} | "
            f"{min(json_float(s['frequency_error_hz']) for s in study.values()):.4f} | {front[:, 0].min():.4f} | "
            f"{min(json_float(s['damping_error']) for s in study.values()):.3g} | {front[:, 1].min():.3g} | "
            f"{json_float(record['hypervolume']['study']):.3f} | "
            f"{json_float(record['hypervolume']['calibrated']):.3f} | "
            f"{best['errors']['frequency_max_relative']:.2e} | {best['errors']['damping_max_relative']:.3f} | "
            f"{best['parameters']['zeta_0']:.3g} | {best['reduced_chi_squared']:.3g} | "
            f"{', '.join(best['undetermined']) or 'none'} | {record['global']['generations']} | "
            f"{'yes' if best['converged'] else 'NO: ' + best['message']} |")
    if nested:
        lines += ["", "Nested models: the best compromise's chi^2 of a model beside that of the model it contains and "
                      "that of the contained optimum in the larger model's box; a larger model above both is a "
                      "defect (an optimum it contains missed).", "",
                  "| model | contains | structure | chi^2 | contained chi^2 | contained optimum in the model | "
                  "holds |", "|---" * 7 + "|"]
        lines += [f"| {row['model']} | {row['contains']} | {row['structure']} | {row['chi_squared']:.6g} | "
                  f"{row['contained_chi_squared']:.6g} | {row['mapped_chi_squared']:.6g} | "
                  f"{'yes' if row['holds'] else 'NO (defect)'} |" for row in nested]
    if spread is not None:
        seeds = list(dict.fromkeys(spread["seed"]))
        lines += ["", f"Spread over study seeds {', '.join(map(str, seeds))}: the best compromise's reduced chi^2 "
                      "calibrated from each seed's study (spread.csv; spread = (max - min) / min).", "",
                  "| model | structure | " + " | ".join(f"seed {seed}" for seed in seeds) + " | spread | "
                  "all converged |", "|---" * (len(seeds) + 4) + "|"]
        for (model, structure), rows in spread.groupby(["model", "structure"], sort=False):
            values = dict(zip(rows["seed"], rows["reduced_chi_squared"]))
            lines.append(f"| {model} | {structure} | " + " | ".join(f"{values[seed]:.4g}" for seed in seeds)
                         + f" | {rows['spread'].iloc[0]:.2%} | {'yes' if rows['converged'].all() else 'no'} |")
    lines += ["", "Acceptance bounds from the data (bounds.csv): each L-infinity error at most "
                  f"{MULTIPLE:g} times the best compromise's as the study evaluates it (the study's zeta_0 for the "
                  f"damping case and its damping rule; the calibrated e_zeta is with the fitted zeta_0) and at least "
                  f"{NOISE_MULTIPLE:g} times the measurement's largest standard uncertainty (the paper's: 2 Hz and "
                  "5e-3 for every structure).", "",
              "| model | structure | damping case | f bound (Hz) | zeta bound | best e_f (Hz) | best e_zeta | "
              "calibrated e_zeta | noise f (Hz) | noise zeta |", "|---" * 10 + "|"]
    lines += [f"| {row.model} | {row.structure} | {row.damping_case} | {row.frequency_bound_hz:.4g} | "
              f"{row.damping_bound:.3g} | {row.best_frequency_error_hz:.4g} | {row.best_damping_error:.3g} | "
              f"{row.calibrated_damping_error:.3g} | {row.noise_frequency_hz:.3g} | {row.noise_damping:.3g} |"
              for row in bounds.itertuples()]
    return "\n".join(lines) + "\n"


def write_markdown(path: Path, records: list[dict], bounds: pd.DataFrame, nested=(),
                   spread: pd.DataFrame | None = None) -> None:
    with atomic_path(path) as temporary:
        temporary.write_text(markdown(records, bounds, nested, spread))
