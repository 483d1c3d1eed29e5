"""The surrogacy confidence of a study at given acceptance bounds (docs/design.md section 7): SC_IJ of one friction
model by subset simulation (``study.subset_simulation``) for each surrogate I, beside the study's own sample counted
at the same bounds, and the reader of a bounds CSV (``surrogacy fit``'s bounds.csv, docs/formats.md).

:func:`surrogacy_confidence` is what ``surrogacy confidence`` runs, on the study, damping case and bounds that
:func:`estimate_inputs` chooses: it writes the CSV (one row per surrogate I and real structure J) and, where the
study's exploration holds the model, the figure of the sample's SC against a factor on the bounds.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np
import pandas as pd

from pipeline.files import check_output_file, check_output_folder
from pipeline.runners import runner
from study.analysis import chunk_errors
from study.datasets import dataset
from study.errors import accepted
from study.figures import plot_confidence_against_scale
from study.subset_simulation import (RegionNotReached, Settings, study_subset_simulation, subset_table,
                                     write_subset_csv)
from study.surrogacy import SurrogacyMatrix, joint_counts, matrix_from_counts
from study import workflow
from study.workflow import StudyFolder


def read_bounds(path: Path, model: str, names: list[str], case: str) -> tuple[np.ndarray, np.ndarray]:
    """Each structure's acceptance bounds (Hz, -), in ``names``' order, for ``model`` from a bounds CSV
    (``surrogacy fit``'s bounds.csv, docs/formats.md), formed for the damping case ``case`` where the file says
    (its ``damping_case`` column); ValueError naming the file and the field otherwise."""
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path}: not a readable bounds CSV ({error})") from None
    missing = [column for column in ("model", "structure", "frequency_bound_hz", "damping_bound")
               if column not in table]
    if missing:
        raise ValueError(f"{path}: field {missing[0]!r}: missing (expected the columns of surrogacy fit's bounds.csv)")
    rows = table[table["model"] == model]
    twice = np.flatnonzero(rows["structure"].duplicated().to_numpy())
    if twice.size:
        structure = rows["structure"].iloc[twice[0]]
        lines = [index + 2 for index in rows.index[rows["structure"] == structure]]  # the header is line 1
        raise ValueError(f"{path}: line {lines[1]}, field 'structure': {structure!r} of model {model!r} given again "
                         f"(first on line {lines[0]}); expected one row per model and structure")
    rows = rows.set_index("structure")
    if "damping_case" in rows and not (rows["damping_case"].astype(str) == case).all():
        raise ValueError(f"{path}: field 'damping_case': bounds formed for {sorted(set(rows['damping_case']))}; "
                         f"expected {case!r}, the damping case of this estimate")
    absent = [name for name in names if name not in rows.index]
    if absent:
        raise ValueError(f"{path}: field 'structure': no row for model {model!r} and structure(s) {absent}")
    frequency, damping = (rows.loc[names, column].to_numpy(float) for column in ("frequency_bound_hz", "damping_bound"))
    if not (np.all(frequency > 0) and np.all(damping > 0)):
        raise ValueError(f"{path}: fields frequency_bound_hz, damping_bound: expected positive values")
    return frequency, damping


def check_bounds_given(bounds: Path | None, frequency_bound: float | None, damping_bound: float | None) -> None:
    """Refuse acceptance bounds not given exactly one way: a bounds CSV ``bounds``, or both ``frequency_bound``
    (Hz) and ``damping_bound`` (-) on every structure. Raises ValueError naming the options as typed."""
    given = [option for option, value in (("--frequency-bound", frequency_bound), ("--damping-bound", damping_bound))
             if value is not None]
    if bounds is not None and given:
        raise ValueError(f"options --bounds and {given[0]}: mutually exclusive; give either --bounds FILE or both "
                         "--frequency-bound and --damping-bound")
    if bounds is None and len(given) < 2:
        raise ValueError("give either --bounds FILE or both --frequency-bound and --damping-bound")


def damping_case(folder: StudyFolder, case: str | None = None) -> str:
    """The linear damping case an estimate on the study ``folder`` uses: ``case`` where given, else the default of
    the study's dataset (``study.datasets.Dataset.default_damping_case``)."""
    return case or dataset(folder.parameters["study"].dataset).default_damping_case


def acceptance_bounds(folder: StudyFolder, model: str, case: str, bounds: Path | None = None,
                      frequency_bound: float | None = None, damping_bound: float | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Each structure's acceptance bounds (S,) Hz and (S,) -, in the order of the study's structures: from the
    bounds CSV ``bounds`` for ``model`` in the damping case ``case`` (``read_bounds``), else ``frequency_bound``
    (Hz) and ``damping_bound`` (-) on every structure (``check_bounds_given``)."""
    names = folder.exploration.names
    if bounds is not None:
        return read_bounds(bounds, model, names, case)
    return np.full(len(names), frequency_bound), np.full(len(names), damping_bound)


class Estimate(NamedTuple):
    """What a confidence estimate runs on: the study, its linear damping case and each structure's acceptance
    bounds, (S,) Hz and (S,) -."""

    folder: StudyFolder
    case: str
    frequency_bounds: np.ndarray
    damping_bounds: np.ndarray


def estimate_inputs(study: Path, model: str, out: Path, case: str | None = None, bounds: Path | None = None,
                    frequency_bound: float | None = None, damping_bound: float | None = None,
                    device: str | None = None) -> Estimate:
    """The study in the folder ``study`` (``study.workflow.read_study``, its evaluations on ``device``: default the
    study's compute device), the damping case (``damping_case``) and the bounds (``acceptance_bounds``) of an
    estimate of ``model`` to be written to the CSV ``out``, checked in this order before anything is computed: the
    bounds given one way (``check_bounds_given``), ``out`` and its levels folder ``<out>.levels`` writable, the
    study readable, the bounds CSV holding the model's rows for that case."""
    check_bounds_given(bounds, frequency_bound, damping_bound)
    check_output_file(out)
    check_output_folder(out.with_name(out.name + ".levels"))
    folder = workflow.read_study(study, device)
    chosen = damping_case(folder, case)
    return Estimate(folder, chosen, *acceptance_bounds(folder, model, chosen, bounds, frequency_bound, damping_bound))


BOUND_SCALES = np.geomspace(0.5, 8.0, 25)  # factors on the chosen bounds of the figure's sample curves


def sample_confidence(folder: StudyFolder, model: str, case: str, frequency_bounds, damping_bounds,
                      scales=(1.0,)):
    """SC_IJ counted on the study's own sample (brute force) chunk by chunk at ``scales`` (a,) times the bounds
    (each structure's own, (S,) Hz and -), where the exploration holds the model (``study.surrogacy
    .matrix_from_counts``: the fields with a leading axis (a,)); None where it does not."""
    if not (folder.paths.designs / model).is_dir():
        return None
    factor = np.asarray(scales, dtype=float)[:, None, None]  # (a, 1, 1) against a chunk's (n, S) errors
    counts = sum(joint_counts(accepted(errors[case].frequency_error_hz, errors[case].damping_error,
                                       factor * frequency_bounds, factor * damping_bounds))
                 for errors in chunk_errors(folder.paths.designs, model, folder.exploration.names, [case]))
    return matrix_from_counts(counts)


def surrogacy_confidence(folder: StudyFolder, model: str, case: str, frequency_bounds, damping_bounds,
                         settings: Settings, out: Path, surrogates: Sequence[str] | None = None,
                         scheduler: str | None = None) -> tuple[pd.DataFrame, Path | None]:
    """SC_IJ of ``model`` at each structure's bounds (``frequency_bounds`` (S,) Hz, ``damping_bounds`` (S,) -) for
    each surrogate I of ``surrogates`` (default every structure: the whole matrix), by subset simulation with
    ``settings`` in the damping case ``case``, each level's state saved under ``<out>.levels/<surrogate>/`` (a
    killed run resumes from its last finished level); the study's own sample counted at the same bounds beside it
    where the exploration holds the model. scheduler: dask.distributed address, ``local`` or None (this process).

    Writes the CSV ``out`` (``study.subset_simulation.SUBSET_COLUMNS``; a surrogate whose region was not reached
    gets rows saying why in ``note``) and, with a sample, the figure ``out`` with suffix .png of the sample's SC
    against ``BOUND_SCALES`` times the bounds. Returns the table and the figure's path (None without a sample).
    """
    names = folder.exploration.names
    sweep = sample_confidence(folder, model, case, frequency_bounds, damping_bounds, np.append(1.0, BOUND_SCALES))
    sample = None if sweep is None else SurrogacyMatrix(*(field[0] for field in sweep))
    levels = out.with_name(out.name + ".levels")
    tables = []
    with runner(scheduler) as tasks:
        for surrogate in surrogates or names:
            try:
                result = study_subset_simulation(folder.exploration, model, surrogate, case, frequency_bounds,
                                                 damping_bounds, settings, levels / surrogate, tasks)
            except RegionNotReached as reason:
                tables.append(subset_table(None, model, names, frequency_bounds, damping_bounds, sample,
                                           names.index(surrogate), str(reason)))
                continue
            tables.append(subset_table(result, model, names, frequency_bounds, damping_bounds, sample))
    table = pd.concat(tables, ignore_index=True)
    write_subset_csv(table, out)
    if sweep is None:
        return table, None
    figure = out.with_suffix(".png")
    plot_confidence_against_scale(figure, model, names, BOUND_SCALES, SurrogacyMatrix(*(field[1:] for field in sweep)),
                                  table)
    return table, figure
