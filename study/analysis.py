"""From the exploration's Parquet rows to the study's answers: acceptance, surrogacy matrices with intervals,
their sensitivity to the bounds, the ANOVA's observations and the Pareto fronts (paper sections 4.4, 5.2).

The analysis streams: ``sample_counts`` reads one model's chunks one at a time, only the error columns
(``study.exploration.read_chunk``), and adds each chunk into reductions that do not grow with the sample:
the joint acceptance counts n_IJ at the acceptance bounds, at every pair of bounds of the sensitivity sweep and
per replicate population for every linear damping case (counts over disjoint sets of designs add), and the
Pareto front of each structure (the non-dominated set of the front so far and the chunk's designs is the front
of every design read so far). Its memory is a chunk's columns, the counts and the fronts, whatever the number
of designs; the parameters of a few designs (the fronts', NSGA-II's seeds) are read back by design index from
their chunks only (``design_rows``). The statistics themselves (counts -> SC with intervals, ANOVA, fronts)
live in ``study.surrogacy``, ``study.anova`` and ``study.pareto``; ``model_errors`` gives a model's whole
error arrays, for small samples and for checking the streamed reductions.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Iterator, Mapping, NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
from tqdm import tqdm

from study.errors import accepted
from study.exploration import StudyError, chunk_path, manifest, read_chunk, read_exploration
from study.pareto import non_dominated
from study.surrogacy import bounds_joint_counts, joint_counts, replicate_from_counts, replicate_joint_counts, \
    replicate_table

PLOTTED_DESIGNS = 100_000
"""Designs of a sample drawn in the error plane of the fronts' figure (the first ones: every replicate
population's first chunks); the fronts themselves are over the whole sample."""


class ModelErrors(NamedTuple):
    """One model's sample on every structure: frequency_error_hz (n, S) Hz, damping_error (n, S) for one
    linear damping case, replicate (n,) labels, design (n,) indices; NaN where not converged."""

    frequency_error_hz: np.ndarray
    damping_error: np.ndarray
    replicate: np.ndarray
    design: np.ndarray


def model_errors(folder: Path, model: str, names: list[str], case: str) -> ModelErrors:
    """The errors of one model's whole sample with linear damping case ``case``, in memory (n rows)."""
    frequency = [f"frequency_error_hz[{name}]" for name in names]
    damping = [f"damping_error[{name}][{case}]" for name in names]
    frame = read_exploration(folder, model, ["design", "replicate", *frequency, *damping])
    return ModelErrors(frame[frequency].to_numpy(float), frame[damping].to_numpy(float),
                       frame["replicate"].to_numpy(int), frame["design"].to_numpy(np.int64))


def model_chunks(folder: Path, model: str) -> list[Path]:
    """One model's chunk files, in the order of their designs. Raises StudyError where there is none."""
    paths = sorted((Path(folder) / model).glob("chunk-*.parquet"))
    if not paths:
        raise StudyError(f"{Path(folder) / model}: no chunk files (run the exploration first)")
    return paths


def chunk_errors(folder: Path, model: str, names: list[str], cases, progress: bool = False) -> Iterator[dict]:
    """One model's errors chunk by chunk, in the order of the designs: per chunk a dict of case -> ModelErrors
    (n_chunk rows) for every linear damping case in ``cases``; a tqdm bar over the chunks when ``progress``."""
    frequency = [f"frequency_error_hz[{name}]" for name in names]
    damping = {case: [f"damping_error[{name}][{case}]" for name in names] for case in cases}
    columns = ["design", "replicate", *frequency, *(column for case in cases for column in damping[case])]
    paths = model_chunks(folder, model)
    for path in tqdm(paths, unit="chunk", desc=f"analysis of {model}", disable=not progress):
        table = read_chunk(path, columns)
        design, replicate = table["design"].to_numpy().astype(np.int64), table["replicate"].to_numpy().astype(int)
        frequency_error = _float_columns(table, frequency)
        yield {case: ModelErrors(frequency_error, _float_columns(table, damping[case]), replicate, design)
               for case in cases}


def _float_columns(table, columns: list[str]) -> np.ndarray:
    """(rows, len(columns)) float64 of a pyarrow table's columns."""
    return np.column_stack([table[column].to_numpy().astype(float) for column in columns])


class Front(NamedTuple):
    """Non-dominated designs of one model's sample on one structure: design (k,) indices, frequency_error_hz
    (k,), damping_error (k,), sorted by frequency error."""

    design: np.ndarray
    frequency_error_hz: np.ndarray
    damping_error: np.ndarray


def front_of(design, frequency_error_hz, damping_error) -> Front:
    """The non-dominated designs (``study.pareto.non_dominated``) of design (n,) indices in increasing order with
    their errors (n,) (Hz, -), sorted by frequency error."""
    points = np.column_stack([frequency_error_hz, damping_error])
    mask = non_dominated(points)
    order = np.argsort(points[mask, 0])
    return Front(np.asarray(design)[mask][order], points[mask, 0][order], points[mask, 1][order])


def sample_front(errors: ModelErrors, structure: int) -> Front:
    """The sample's Pareto front in the error plane of one structure (paper Fig. 6)."""
    return front_of(errors.design, errors.frequency_error_hz[:, structure], errors.damping_error[:, structure])


def merged_front(front: Front, design, frequency_error_hz, damping_error) -> Front:
    """The front of the designs of ``front`` and further designs (n,) of larger indices, in increasing order,
    with their errors: a design off the front of either set is dominated in the union, so the union's front is
    the front of the whole sample read so far; the designs kept in index order, so that ties come out as
    ``sample_front`` of the whole sample orders them."""
    order = np.argsort(front.design)
    return front_of(np.concatenate([front.design[order], design]),
                    np.concatenate([front.frequency_error_hz[order], frequency_error_hz]),
                    np.concatenate([front.damping_error[order], damping_error]))


class SampleCounts(NamedTuple):
    """One model's sample reduced over its chunks (``sample_counts``), S structures.

    n_designs: designs read; joint_counts: (S, S) n_IJ at the acceptance bounds (``study.surrogacy``);
    bounds_joint_counts: (a, b, S, S) n_IJ at each pair of the sweep's bounds; replicate_labels: (R,) sorted;
    replicate_joint_counts: linear damping case -> (R, S, S) n_IJ of each replicate population at the acceptance
    bounds; fronts: (S,) Front of each structure; plotted: ModelErrors of the first ``PLOTTED_DESIGNS`` designs.
    All but replicate_joint_counts are of the analysed damping case.
    """

    n_designs: int
    joint_counts: np.ndarray
    bounds_joint_counts: np.ndarray
    replicate_labels: np.ndarray
    replicate_joint_counts: dict
    fronts: list
    plotted: ModelErrors


def sample_counts(folder: Path, model: str, names: list[str], cases, case: str, frequency_tolerance_hz: float,
                  damping_tolerance: float, frequency_bounds_hz, damping_bounds, plotted_designs: int = PLOTTED_DESIGNS,
                  progress: bool = True) -> SampleCounts:
    """Every reduction the analysis needs of one model's sample, in one pass over its chunks (module docstring).

    names: (S,) structures; cases: every linear damping case (their replicate counts, for the ANOVA); case: the
    one analysed (counts, sweep, fronts); frequency_tolerance_hz (Hz), damping_tolerance (-): the acceptance
    bounds; frequency_bounds_hz (a,) Hz, damping_bounds (b,): the sweep's. Memory: one chunk's error columns,
    (a b + R |cases| + 1) S^2 counts, the fronts and the plotted designs' errors, whatever the sample's size.
    """
    n_structures = len(names)
    joint = np.zeros((n_structures, n_structures), dtype=np.int64)
    sweep = np.zeros((np.size(frequency_bounds_hz), np.size(damping_bounds), n_structures, n_structures),
                     dtype=np.int64)
    replicates = {name: {} for name in cases}
    empty = np.zeros(0)
    fronts = [Front(np.zeros(0, dtype=np.int64), empty, empty)] * n_structures
    plotted, n_designs = [], 0
    for errors_of in chunk_errors(folder, model, names, cases, progress):
        for name, errors in errors_of.items():
            labels, counts = replicate_joint_counts(accepted(errors.frequency_error_hz, errors.damping_error,
                                                             frequency_tolerance_hz, damping_tolerance),
                                                    errors.replicate)
            for label, count in zip(labels.tolist(), counts):
                replicates[name][label] = replicates[name].get(label, 0) + count
        errors = errors_of[case]
        joint += joint_counts(accepted(errors.frequency_error_hz, errors.damping_error, frequency_tolerance_hz,
                                       damping_tolerance))
        sweep += bounds_joint_counts(errors.frequency_error_hz, errors.damping_error, frequency_bounds_hz,
                                     damping_bounds)
        fronts = [merged_front(front, errors.design, errors.frequency_error_hz[:, index],
                               errors.damping_error[:, index]) for index, front in enumerate(fronts)]
        if n_designs < plotted_designs:
            plotted.append(ModelErrors(*(values[:plotted_designs - n_designs] for values in errors)))
        n_designs += len(errors.design)
    labels = np.array(sorted(replicates[case]), dtype=int)
    replicate_counts = {name: np.array([replicates[name][label] for label in labels], dtype=np.int64)
                        for name in cases}
    return SampleCounts(n_designs, joint, sweep, labels, replicate_counts, fronts,
                        ModelErrors(*(np.concatenate(values) for values in zip(*plotted))))


def anova_observations(counts: Mapping[str, SampleCounts], names: list[str]) -> pd.DataFrame:
    """One surrogacy confidence per (surrogate, real, model, linear damping case, replicate population): the
    observations of the paper's Table 6 ANOVA (NaN where the replicate's surrogate accepted no design), from each
    model's ``SampleCounts`` (model -> counts)."""
    return pd.concat([replicate_table(replicate_from_counts(sample.replicate_labels, replicate_counts), names,
                                      model, case)
                      for model, sample in counts.items()
                      for case, replicate_counts in sample.replicate_joint_counts.items()], ignore_index=True)


def design_rows(folder: Path, model: str, designs, columns: list[str]) -> np.ndarray:
    """(k, len(columns)) float values of ``columns`` of designs (k,) (indices in the model's sample, any order,
    repeats allowed), in that order, reading only the chunks that hold them (design d in chunk d // chunk_size,
    the manifest's). Raises StudyError naming the chunk file that lacks a design."""
    designs = np.asarray(designs, dtype=np.int64).ravel()
    chunk_size = int(manifest(folder)["sample"]["chunk_size"])
    values = np.empty((designs.size, len(columns)))
    chunks = designs // chunk_size
    for chunk in np.unique(chunks).tolist():
        path = chunk_path(folder, model, chunk)
        table = read_chunk(path, ["design", *columns])
        stored = table["design"].to_numpy()
        wanted = np.flatnonzero(chunks == chunk)
        rows = np.minimum(np.searchsorted(stored, designs[wanted]), len(stored) - 1)
        absent = designs[wanted][stored[rows] != designs[wanted]]
        if absent.size:
            raise StudyError(f"{path}: no row of design {absent[0]} (expected designs {chunk * chunk_size} to "
                             f"{(chunk + 1) * chunk_size - 1}); run the explore step with --restart-stale")
        values[wanted] = _float_columns(table, columns)[rows]
    return values


def string_counts(column: pa.ChunkedArray) -> dict[str, int]:
    """Count of each non-empty string of a string column (dictionary-encoded or not, as the chunks write the
    reasons), in the order of first appearance (pyarrow's value_counts: no Python object per row)."""
    return {row["values"]: row["counts"] for row in pc.value_counts(column).to_pylist() if row["values"]}


def reason_counts(folder: Path, model: str, names: list[str]) -> tuple[int, dict]:
    """(designs, structure -> Counter of the reasons of its designs not converged) of one model's sample, chunk
    by chunk (only the reason columns read); each Counter in the order in which the reasons first appear."""
    columns = [f"reason[{name}]" for name in names]
    reasons, n_designs = {name: Counter() for name in names}, 0
    for path in model_chunks(folder, model):
        table = read_chunk(path, columns)
        n_designs += table.num_rows
        for name, column in zip(names, columns):
            reasons[name].update(string_counts(table[column]))
    return n_designs, reasons


def representative_designs(front: Front, frequency_tolerance_hz: float, damping_tolerance: float,
                           count: int = 3) -> np.ndarray:
    """``count`` designs spread along a front (paper Figs. 9-11): its two ends and the design nearest the origin
    with each error measured in its acceptance bound (the knee), then evenly between; indices into the front."""
    if len(front.design) <= count:
        return np.arange(len(front.design))
    scaled = np.hypot(front.frequency_error_hz / frequency_tolerance_hz, front.damping_error / damping_tolerance)
    chosen = [0, len(front.design) - 1, int(np.argmin(scaled))]
    for position in np.linspace(0, len(front.design) - 1, count + 2)[1:-1].round().astype(int):
        if len(set(chosen)) >= count:
            break
        chosen.append(int(position))
    return np.array(sorted(set(chosen))[:count])
