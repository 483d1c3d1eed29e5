"""Design exploration: every chunk of every model's sample evaluated on every structure, streamed to Parquet.

A task is one chunk of the sample (``study.designs``) for every friction model whose file of it is missing: its
designs are regenerated from the seed, evaluated on each structure (``study.errors.design_errors``; the stuck modes
formed once for the models with the same stuck joint), reduced to one row per design, and written by the process
that evaluated it: ``<folder>/<model>/chunk-<c>.parquet``, model by model, by an atomic rename, so a run killed at
any point leaves whole chunk files only, and a rerun evaluates exactly the files that are missing (nothing lost,
nothing repeated). A task returns only its timing (``ChunkTiming``); the process driving the study checks each
written chunk's study key and keeps the count. Memory stays that of the chunks in flight.

Chunks run on the runner the caller passes (``pipeline.runners``): in this process, or on a dask.distributed
cluster (a LocalCluster, or a scheduler address whose workers see the results folder: the same machine, or a shared
file system): the structures are shared with the workers once, the chunks farmed out with
``pipeline.runners.IN_FLIGHT_PER_SLOT`` per worker thread in flight, and the files are the same floats as the
serial run (a chunk's result depends on its seed and inputs only). The workers' idle
share (``Explored.idle_fraction``) says how well the cluster was kept busy.

Row of a design (Parquet columns; S = structure name, Z = linear damping case):
    model, design (index in the model's sample), chunk, replicate, seed;
    the design's parameters, named as ``nonlinear.joint.parameter_names`` (N, N/m, -);
    ``frequency_error_hz[S]``  L-infinity frequency error (Hz), NaN when not converged;
    ``damping_error[S][Z]``    L-infinity damping-ratio error with zeta_0 of case Z;
    ``converged[S]``           every level converged; ``reason[S]`` why not ('' when converged);
    ``stuck_frequency_hz[S]``  the design's low-amplitude frequency of the target mode (Hz).
The file's metadata holds the study key (hash of the structures' measurements, the sample and the damping
cases): a folder holding another study's chunks is refused, never mixed. A chunk of this study's key is checked row
by row against the designs its seed regenerates (``chunk_defect``: count, design indices, model, seed, parameters):
one copied from another chunk, rewritten with fewer rows or taken from another model is refused by the analysis and
discarded and recomputed by the exploration, named.
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
from tqdm import tqdm

from nonlinear.condensation import StuckModeCache, modal_split
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import parameter_limits, parameter_names, tangential_rows, to_unit
from nonlinear.parameters import FrictionParameterError
from pipeline.files import atomic_path, folder_lock, sha256_json, sweep_partial_files, write_json
from pipeline.runners import SERIAL
from study.designs import chunk_designs
from study.errors import DAMPING_RULES, DesignErrors, design_errors
from study.structures import Structure

DESIGN_TOLERANCE = 1e-9
"""Largest difference between a chunk's stored parameters and those its seed regenerates, on Table 3's sampling
scale as a share of each parameter's range (unit designs, ``nonlinear.joint.to_unit``): exp and log round to about
1e-16 there on any numpy build, while a design of another chunk, seed or model differs by about the width of a stratum
(1 / chunk_size) or more in almost every parameter."""
class StudyError(ValueError):
    """A study's inputs or its results folder are inconsistent; the message names the file or field."""


@dataclass(frozen=True)
class Sample:
    """The designs of each model: n_designs in chunks of chunk_size, seed, replicate populations."""

    seed: int = 2024
    n_designs: int = 2000
    chunk_size: int = 500
    n_replicates: int = 10

    def __post_init__(self):
        for name in ("n_designs", "chunk_size", "n_replicates"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1; got {getattr(self, name)}")

    @property
    def n_chunks(self) -> int:
        return -(-self.n_designs // self.chunk_size)

    def chunk_length(self, chunk: int) -> int:
        return min(self.chunk_size, self.n_designs - chunk * self.chunk_size)


@dataclass(frozen=True)
class Exploration:
    """What a study evaluates: the structures (same patch groups), friction models, sample, the linear
    damping cases (case name -> value of each structure, in the structures' order) and the rule that makes a
    case's value each design's zeta_0 (``study.errors.DAMPING_RULES``), and the device that solves the stuck modes
    and the QSMA levels (``nonlinear.compute_devices``: "cpu" or "cuda"; not in the study key, the results agreeing to
    round-off)."""

    structures: tuple[Structure, ...]
    models: tuple[str, ...]
    sample: Sample
    damping_cases: dict
    damping_rule: str = "added"
    device: str = "cpu"

    def __post_init__(self):
        unknown = [model for model in self.models if model not in MODEL_NAMES]
        if unknown:
            raise StudyError(f"models: unknown friction model(s) {unknown}; expected some of {MODEL_NAMES}")
        groups = {max(structure.space.superelement.patch_groups) + 1 for structure in self.structures}
        if len(groups) != 1:
            raise StudyError("structures: one design must fit every structure, but the numbers of patch groups "
                             f"differ: {sorted(groups)}")
        for model in self.models:
            try:
                parameter_names(model, self.n_groups)
            except FrictionParameterError as error:
                raise StudyError(f"models: {model!r} does not fit these structures ({self.n_groups} patch "
                                 f"group(s)): {error}") from None
        if self.damping_rule not in DAMPING_RULES:
            raise StudyError(f"damping_rule {self.damping_rule!r}: expected one of {DAMPING_RULES}")
        for case, values in self.damping_cases.items():
            if len(values) != len(self.structures):
                raise StudyError(f"damping case {case!r}: {len(values)} values for {len(self.structures)} structures")

    @property
    def names(self) -> list[str]:
        return [structure.name for structure in self.structures]

    @property
    def n_groups(self) -> int:
        return max(self.structures[0].space.superelement.patch_groups) + 1

    def key(self) -> str:
        """Hash of everything a chunk's rows depend on."""
        return sha256_json({
            "structures": [{"name": s.name, "amplitude": s.measurement.amplitude.tolist(),
                            "frequency_hz": s.measurement.frequency_hz.tolist(),
                            "damping": s.measurement.damping.tolist(),
                            "eigenvalues": s.space.eigenvalues.tolist(), "reference": s.space.reference.tolist()}
                           for s in self.structures],
            "sample": self.sample.__dict__, "damping_cases": {k: list(v) for k, v in self.damping_cases.items()},
            "damping_rule": self.damping_rule})


def chunk_path(folder: Path, model: str, chunk: int) -> Path:
    return Path(folder) / model / f"chunk-{chunk:06d}.parquet"


def chunk_tables(exploration: Exploration, chunk: int, models=None, splits=None) -> dict[str, pa.Table]:
    """Evaluate one chunk of each model's sample (``models``, default the study's) on every structure: the rows of
    its designs (module docstring), by model. splits: the structures' ``modal_split``, formed here when not
    given."""
    sample = exploration.sample
    models = exploration.models if models is None else tuple(models)
    designs = chunk_designs(sample.seed, models, chunk, sample.chunk_length(chunk), exploration.n_groups)
    errors = models_errors(exploration, designs, splits)
    first = chunk * sample.chunk_size
    cases = list(exploration.damping_cases)
    tables = {}
    for model in models:
        n = len(designs[model])
        columns = {"model": pa.array([model] * n).dictionary_encode(),
                   "design": np.arange(first, first + n, dtype=np.int64),
                   "chunk": np.full(n, chunk, dtype=np.int32),
                   "replicate": np.full(n, chunk % sample.n_replicates, dtype=np.int16),
                   "seed": np.full(n, sample.seed, dtype=np.int64)}
        columns.update(zip(parameter_names(model, exploration.n_groups), designs[model].T))
        for structure, structure_error in zip(exploration.structures, errors[model]):
            name = structure.name
            columns[f"frequency_error_hz[{name}]"] = structure_error.frequency_error_hz
            columns.update({f"damping_error[{name}][{case}]": structure_error.damping_error[:, k]
                            for k, case in enumerate(cases)})
            columns[f"converged[{name}]"] = structure_error.converged
            columns[f"reason[{name}]"] = pa.array(structure_error.reason).dictionary_encode()
            columns[f"stuck_frequency_hz[{name}]"] = structure_error.stuck_frequency_hz
        tables[model] = pa.table(columns)
    return tables


def models_errors(exploration: Exploration, designs: dict, splits=None,
                  structures=None) -> dict[str, list[DesignErrors]]:
    """``study.errors.design_errors`` of each model's designs (model -> (n, d)) on each structure (all, or the
    indices in ``structures``, in that order), damping errors for every damping case in the exploration's order.
    On each structure the stuck modes are formed once for the models whose designs have the same stuck joint
    (``nonlinear.condensation.StuckModeCache``; the sample's common columns, ``study.designs``). splits: the
    structures' ``modal_split`` (all of them), formed here when not given."""
    indices = range(len(exploration.structures)) if structures is None else structures
    errors = {model: [] for model in designs}
    for index in indices:
        structure = exploration.structures[index]
        zeta0 = [values[index] for values in exploration.damping_cases.values()]
        stuck = StuckModeCache(structure.space, None if splits is None else splits[index],
                               tangential_rows(structure.space.superelement.n_patches), exploration.device)
        for model, model_designs in designs.items():
            errors[model].append(design_errors(structure, model, model_designs, zeta0, stuck=stuck,
                                               rule=exploration.damping_rule, device=exploration.device))
    return errors


def structure_errors(exploration: Exploration, model: str, designs, splits=None,
                     structures=None) -> list[DesignErrors]:
    """``models_errors`` of one model's ``designs`` (n, d): its errors on each structure."""
    return models_errors(exploration, {model: designs}, splits, structures)[model]


def write_chunk(table: pa.Table, destination: Path, key: str) -> None:
    """Write a chunk's rows atomically, the study key in the file's metadata."""
    metadata = {b"study_key": key.encode(), b"seed": str(int(table["seed"][0])).encode()}
    with atomic_path(destination) as temporary:
        pq.write_table(table.replace_schema_metadata(metadata), temporary)


def stored_key(path: Path) -> str | None:
    """The study key in a chunk file's metadata ('' where it has none); None where the file cannot be read as
    Parquet (truncated, or another kind of file)."""
    try:
        return (pq.read_schema(path).metadata or {}).get(b"study_key", b"").decode()
    except (pa.ArrowException, OSError):
        return None


def finished_chunks(exploration: Exploration, folder: Path) -> set[tuple[str, int]]:
    """(model, chunk) already written for this study. Raises StudyError for a chunk file of another study or
    one that cannot be read."""
    key, done = exploration.key(), set()
    for model in exploration.models:
        for chunk in range(exploration.sample.n_chunks):
            path = chunk_path(folder, model, chunk)
            if not path.exists():
                continue
            stored = stored_key(path)
            if stored is None:
                raise StudyError(f"{path}: not a readable Parquet chunk (truncated?); run the explore step, "
                                 "which recomputes it (--steps explore analyse)")
            if stored != key:
                raise _another_study(path, stored, key)
            done.add((model, chunk))
    return done


def _another_study(path: Path, stored: str, key: str) -> StudyError:
    return StudyError(f"{path}: written by another study (study_key {stored[:12]}..., this study {key[:12]}...); "
                      "use another results folder, or discard them with --restart-stale")


def chunk_defect(exploration: Exploration, model: str, chunk: int, path: Path, designs=None) -> str | None:
    """Why the rows of the chunk file ``path`` are not chunk ``chunk`` of ``model``'s sample as the seed regenerates
    it (``study.designs.chunk_designs``): another number of rows, other design indices, another model or seed, or
    parameters off the regenerated ones by more than ``DESIGN_TOLERANCE`` (a chunk copied from another, rewritten
    with fewer rows, or of another model or study); None when they are those designs. designs: the regenerated
    parameters (chunk length, d) in physical units, formed here when not given."""
    sample = exploration.sample
    names = parameter_names(model, exploration.n_groups)
    try:
        table = pq.read_table(path, columns=["model", "design", "seed", *names])
    except (pa.ArrowException, OSError) as error:
        return f"not a readable chunk of the study ({_first_line(error)})"
    first, length = chunk * sample.chunk_size, sample.chunk_length(chunk)
    if table.num_rows != length:
        return f"{table.num_rows} row(s), expected the {length} designs {first} to {first + length - 1}"
    stored, expected = table["design"].to_numpy(), np.arange(first, first + length)
    if not np.array_equal(stored, expected):
        row = int(np.flatnonzero(stored != expected)[0])
        return f"row {row} holds design {stored[row]}, expected designs {first} to {first + length - 1}"
    for column, value in (("model", model), ("seed", sample.seed)):
        other = [found for found in pc.unique(table[column]).to_pylist() if found != value]
        if other:
            return f"rows of {column} {other[0]!r}, expected {value!r}"
    if designs is None:
        designs = chunk_designs(sample.seed, (model,), chunk, length, exploration.n_groups)[model]
    limits = parameter_limits(model, exploration.n_groups)
    parameters = np.column_stack([table[name].to_numpy() for name in names])
    off = ~(np.abs(to_unit(parameters, *limits) - to_unit(designs, *limits)) <= DESIGN_TOLERANCE)
    if off.any():
        row, column = np.argwhere(off)[0]
        return (f"design {first + row}: {names[column]} = {parameters[row, column]:.9g}, the seed gives "
                f"{designs[row, column]:.9g}")
    return None


def defective_chunks(exploration: Exploration, folder: Path):
    """(path, why) of each chunk file of this study's sample in ``folder``, of this study's key, whose rows are not
    the designs its seed regenerates (``chunk_defect``), chunk by chunk; each chunk's designs regenerated once for
    every model."""
    sample, key = exploration.sample, exploration.key()
    for chunk in range(sample.n_chunks):
        paths = {model: chunk_path(folder, model, chunk) for model in exploration.models}
        paths = {model: path for model, path in paths.items() if path.exists() and stored_key(path) == key}
        if not paths:
            continue
        designs = chunk_designs(sample.seed, tuple(paths), chunk, sample.chunk_length(chunk), exploration.n_groups)
        for model, path in paths.items():
            defect = chunk_defect(exploration, model, chunk, path, designs[model])
            if defect is not None:
                yield path, defect


def check_explored(exploration: Exploration, folder: Path) -> None:
    """Refuse to analyse ``folder`` unless it holds exactly this study's exploration: its manifest with this
    study's key (the same measurements, superelements, sample and damping cases), and every chunk of every model,
    readable, of this study, and no other, each holding the rows of the designs its seed regenerates
    (``chunk_defect``). Raises StudyError naming the first file that differs and what to run."""
    folder = Path(folder)
    recorded = manifest(folder).get("study_key")
    if recorded != exploration.key():
        raise StudyError(f"{folder / 'exploration.json'}: explored for other inputs (study_key {str(recorded)[:12]}"
                         f"...; the current measurements, superelements, sample and damping cases give "
                         f"{exploration.key()[:12]}...); run the explore step again (--steps explore analyse "
                         "--restart-stale)")
    finished_chunks(exploration, folder)
    for model in exploration.models:
        expected = {chunk_path(folder, model, chunk) for chunk in range(exploration.sample.n_chunks)}
        missing = sorted(expected - set((folder / model).glob("chunk-*.parquet")))
        if missing:
            raise StudyError(f"{missing[0]}: missing ({len(missing)} of the {len(expected)} chunks of {model}); "
                             "run the explore step to compute them (--steps explore analyse)")
        extra = sorted(set((folder / model).glob("chunk-*.parquet")) - expected)
        if extra:
            raise StudyError(f"{extra[0]}: not a chunk of this study (its sample has {len(expected)} chunks per "
                             "model); remove it, or rerun the explore step with --restart-stale")
    for path, defect in defective_chunks(exploration, folder):
        raise StudyError(f"{path}: not the designs its seed regenerates ({defect}); run the explore step, which "
                         "discards and recomputes it (--steps explore analyse)")


class ChunkTiming(NamedTuple):
    """One task: the chunk and the models whose files it wrote, the process that evaluated and wrote them
    (host:pid) and when (s since the epoch on that host)."""

    models: tuple[str, ...]
    chunk: int
    worker: str
    start: float
    end: float


def evaluate_chunk(exploration: Exploration, folder: Path, chunk: int, models: tuple[str, ...]) -> ChunkTiming:
    """One task, on a worker or in this process: the chunk's rows of each of ``models`` on every structure (the
    process's modal splits), each model's written atomically to its file in ``folder``."""
    start = time.time()
    for model, table in chunk_tables(exploration, chunk, models, process_splits(exploration)).items():
        write_chunk(table, chunk_path(folder, model, chunk), exploration.key())
    return ChunkTiming(tuple(models), chunk, f"{socket.gethostname()}:{os.getpid()}", start, time.time())


class Explored(NamedTuple):
    """An exploration run: the chunk files of the whole study, the timing of each chunk this run evaluated, the
    run's wall time (s, from the first task's submission to the last file checked) and the worker threads."""

    paths: list[Path]
    timings: list[ChunkTiming]
    wall_seconds: float
    threads: int

    @property
    def idle_fraction(self) -> float:
        """Share of the worker threads' time not spent evaluating or writing a chunk,
        1 - sum(end - start) / (threads x wall time); NaN when the run evaluated nothing."""
        if not self.timings or self.wall_seconds <= 0:
            return float("nan")
        busy = sum(timing.end - timing.start for timing in self.timings)
        return max(0.0, 1.0 - busy / (self.threads * self.wall_seconds))


_SPLITS: dict = {}  # study key -> the structures' modal splits, in each process


def process_splits(exploration: Exploration):
    """The structures' modal splits, formed once per process and study."""
    key = exploration.key()
    if key not in _SPLITS:
        _SPLITS.clear()
        _SPLITS[key] = [modal_split(structure.space) for structure in exploration.structures]
    return _SPLITS[key]


def discard_stale_chunks(exploration: Exploration, folder: Path) -> list[Path]:
    """Remove the chunk files in ``folder`` that another study wrote (other inputs: a changed measurement,
    superelement or sample), so that this study recomputes them; returns them. Only chunk files are touched."""
    key, stale = exploration.key(), []
    for path in sorted(Path(folder).glob("*/chunk-*.parquet")):
        if stored_key(path) != key:
            path.unlink()
            stale.append(path)
    return stale


def refuse_other_studies(exploration: Exploration, folder: Path) -> None:
    """Raise StudyError naming the first readable chunk file of the sample in ``folder`` (model by model, chunk by
    chunk) that another study wrote (another key)."""
    key = exploration.key()
    for model in exploration.models:
        for chunk in range(exploration.sample.n_chunks):
            path = chunk_path(folder, model, chunk)
            stored = stored_key(path) if path.exists() else None
            if stored is not None and stored != key:
                raise _another_study(path, stored, key)


def discard_damaged_chunks(exploration: Exploration, folder: Path) -> list[Path]:
    """Remove the chunk files in ``folder`` that cannot be read as Parquet (truncated: a disk that filled up, a
    copy that stopped) and those of this study whose rows are not the designs their seed regenerates
    (``defective_chunks``: copied from another chunk, rewritten with fewer rows, of another model), so that the
    exploration recomputes them; returns them, each said on one line of stderr with the reason."""
    damaged = [(path, "not a readable Parquet chunk (truncated?)")
               for path in sorted(Path(folder).glob("*/chunk-*.parquet")) if stored_key(path) is None]
    damaged += [(path, f"not the designs its seed regenerates ({defect})")
                for path, defect in defective_chunks(exploration, folder)]
    for path, reason in damaged:
        path.unlink()
        tqdm.write(f"{path}: {reason}: removed, recomputing", file=sys.stderr)
    return [path for path, _ in damaged]


def explore(exploration: Exploration, folder: Path, runner=SERIAL, progress: bool = True,
            restart_stale: bool = False) -> Explored:
    """Evaluate every chunk not yet in ``folder`` on ``runner`` (``pipeline.runners``: in this process, or on a
    cluster whose workers write into ``folder``); returns the run (``Explored``: the chunk files of the whole
    study, the timings, the workers' idle share). Holds the folder's lock (a second run into it is
    refused with ``pipeline.files.FolderBusyError``) and first removes the temporary files a killed run left.
    A chunk another study wrote is refused (StudyError) before any file is changed, or with ``restart_stale``
    discarded and recomputed. A chunk file that cannot be read (truncated) or whose rows are not the designs its
    seed regenerates is removed and recomputed, said on stderr. Writes ``<folder>/exploration.json`` (the study
    key, sample, models, structures and damping cases) before the first chunk."""
    folder = Path(folder)
    with folder_lock(folder):
        sweep_partial_files(folder)
        if not restart_stale:
            refuse_other_studies(exploration, folder)
        discard_damaged_chunks(exploration, folder)
        if restart_stale:
            discard_stale_chunks(exploration, folder)
        return _explore(exploration, folder, runner, progress)


def _explore(exploration: Exploration, folder: Path, runner, progress: bool) -> Explored:
    done = finished_chunks(exploration, folder)
    _write_manifest(exploration, folder)
    pending = [(chunk, missing) for chunk in range(exploration.sample.n_chunks)
               if (missing := tuple(model for model in exploration.models if (model, chunk) not in done))]
    key = exploration.key()
    total = len(exploration.models) * exploration.sample.n_chunks
    threads = runner.slots
    timings = []
    start = time.perf_counter()
    with tqdm(total=total, initial=total - sum(len(models) for _, models in pending), unit="chunk",
              disable=not progress, desc=f"designs ({exploration.sample.chunk_size} per chunk and model)") as bar:
        shared = runner.share(exploration)
        resolved = folder.resolve()  # workers may run in another working directory
        for timing in runner.completed(evaluate_chunk, ((shared, resolved, *task) for task in pending)):
            for model in timing.models:
                path = chunk_path(folder, model, timing.chunk)
                if stored_key(path) != key:
                    raise StudyError(f"{path}: the worker {timing.worker} reported it written, but it is missing "
                                     "or not this study's chunk here; the workers must write to the folder this "
                                     "process reads (the same machine, or a shared file system)")
            timings.append(timing)
            bar.update(len(timing.models))
    paths = [chunk_path(folder, model, chunk) for model in exploration.models
             for chunk in range(exploration.sample.n_chunks)]
    return Explored(paths, timings, time.perf_counter() - start, threads)


def _write_manifest(exploration: Exploration, folder: Path) -> None:
    write_json(folder / "exploration.json", {
        "study_key": exploration.key(), "sample": exploration.sample.__dict__, "models": list(exploration.models),
        "structures": [{"name": s.name, "mode_choice": s.mode_choice, "provenance": s.measurement.provenance,
                        "source": s.measurement.source, "levels": len(s.measurement.amplitude)}
                       for s in exploration.structures],
        "damping_cases": {case: list(map(float, values)) for case, values in exploration.damping_cases.items()},
        "damping_rule": exploration.damping_rule, "columns": "see study.exploration module docstring"})


def read_exploration(folder: Path, model: str, columns: list[str] | None = None):
    """The rows of one model's sample (pandas DataFrame, ordered by design), optionally only ``columns``."""
    paths = sorted((Path(folder) / model).glob("chunk-*.parquet"))
    if not paths:
        raise StudyError(f"{Path(folder) / model}: no chunk files (run the exploration first)")
    frame = pa.concat_tables([read_chunk(path, columns) for path in paths]).to_pandas()
    return frame.sort_values("design").reset_index(drop=True) if "design" in frame else frame


def read_chunk(path: Path, columns: list[str] | None = None) -> pa.Table:
    """One chunk file's rows (``columns`` only, when given). Raises StudyError naming the file when it cannot be
    read as a chunk of the study (truncated, not Parquet, a column missing)."""
    try:
        return pq.read_table(path, columns=columns)
    except (pa.ArrowException, OSError) as error:
        raise StudyError(f"{path}: not a readable chunk of the study ({_first_line(error)}); run the explore step, "
                         "which recomputes it") from None


def _first_line(error: Exception) -> str:
    return (str(error).splitlines() or [type(error).__name__])[0]


def manifest(folder: Path) -> dict:
    """The exploration's manifest (``exploration.json``)."""
    path = Path(folder) / "exploration.json"
    if not path.exists():
        raise StudyError(f"{path}: missing (run the exploration first)")
    try:
        record = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise StudyError(f"{path}: not a JSON manifest ({error}); run the explore step again") from None
    if not isinstance(record, dict):
        raise StudyError(f"{path}: expected a JSON object; run the explore step again")
    return record
