"""The exploration on disk, with real components started as a user starts them: a study killed with SIGKILL
resumes without losing or repeating a chunk, a dask.distributed LocalCluster and an external `dask scheduler`
with two `dask worker` processes write the same rows as the serial run, another Parquet reader than pyarrow
reads the same values and metadata, and a folder of another study is refused. The analysis refuses a folder that
is not the whole exploration of the current inputs (a chunk deleted, cut short or added, a measurement edited), a
truncated chunk is recomputed and named, a full disk names the chunk, and the ``surrogacy study`` command refuses
a folder of another dataset and a measurement out of range before any work.

The study: two friction models on the ASB configurations C1-C3 (reduced models and measured backbones in
../shared/data; the tests skip, naming the path, where they are absent) at 8 levels, 8 chunks of 30 designs per
model, some designs not converged (NaN errors). A chunk takes milliseconds; a study's run is dominated by
starting processes (a few seconds each).
"""

import json
import logging
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import nonlinear.condensation as condensation
import study.exploration as exploration_module
from experiment.backbone_files import read_asb_backbone
from locations import ASB_MODELS, REPOSITORY
from nonlinear.joint import parameter_names
from pipeline import runners
from stage_runs import device_calls
from study.exploration import (ChunkTiming, Explored, Exploration, Sample, StudyError, check_explored, chunk_path,
                               chunk_tables, explore, finished_chunks, manifest, read_exploration, write_chunk)
from study.structures import asb_superelement, structure

CONFIGURATIONS = ("C1", "C2", "C3")
MODELS = ("jenkins", "iwan4")
SAMPLE = Sample(seed=11, n_designs=240, chunk_size=30, n_replicates=3)  # 8 chunks per model
DAMPING_CASES = {"low": (2e-4, 3e-4, 2e-4), "high": (1e-3, 1.5e-3, 1e-3)}  # zeta_0 of C1, C2, C3
N_LEVELS = 8
STARTUP_TIMEOUT_S = 120  # a process importing numba, scipy and the project on a busy 2-core machine
KILLED_AT_WRITE = 10  # the killed study finishes chunks 0-3 of both models and jenkins' chunk 4, dies writing iwan4's


def asb_files(configuration: str) -> tuple[Path, Path]:
    """The ASB configuration's reduced model and measured backbone."""
    models = ASB_MODELS
    return (models / f"MAT_NULLRED_{configuration}.mat",
            models.parent / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat")


def asb_exploration(n_levels: int = N_LEVELS, sample: Sample = SAMPLE) -> Exploration:
    """The study of these tests, built from the files as a user's script builds it (the killed study's
    subprocess imports this function)."""
    structures = []
    for configuration in CONFIGURATIONS:
        model_path, backbone_path = asb_files(configuration)
        structures.append(structure(configuration, asb_superelement(model_path), read_asb_backbone(backbone_path),
                                    DAMPING_CASES["low"][len(structures)], n_levels=n_levels,
                                    measurement_path=str(backbone_path)))
    return Exploration(tuple(structures), MODELS, sample, DAMPING_CASES)


@pytest.fixture(scope="module")
def exploration() -> Exploration:
    for configuration in CONFIGURATIONS:
        for path in asb_files(configuration):
            if not path.exists():
                pytest.skip(f"ASB data not available at {path} (shared data folder absent)")
    return asb_exploration()


@pytest.fixture(scope="module")
def serial_folder(exploration, tmp_path_factory) -> Path:
    """The uninterrupted serial run: every other run is compared with it."""
    folder = tmp_path_factory.mktemp("serial")
    explore(exploration, folder, progress=False)
    return folder


def all_chunks(exploration: Exploration) -> set[tuple[str, int]]:
    return {(model, chunk) for model in exploration.models for chunk in range(exploration.sample.n_chunks)}


def chunk_files(folder: Path) -> set[tuple[str, int]]:
    """(model, chunk) of every chunk file a reader sees in ``folder``."""
    return {(path.parent.name, int(re.fullmatch(r"chunk-(\d+)", path.stem)[1]))
            for path in Path(folder).glob("*/chunk-*.parquet")}


def file_identities(folder: Path) -> dict[str, tuple[int, int, int]]:
    """Inode, size and modification time of every file under ``folder``: a rewrite changes them."""
    return {str(path.relative_to(folder)): (path.stat().st_ino, path.stat().st_size, path.stat().st_mtime_ns)
            for path in Path(folder).rglob("*") if path.is_file()}


def file_contents(folder: Path) -> dict[str, bytes]:
    """The bytes of every file under ``folder``, by path relative to it."""
    return {str(path.relative_to(folder)): path.read_bytes() for path in Path(folder).rglob("*") if path.is_file()}


def assert_same_chunk(path: Path, reference: Path) -> None:
    """Same schema and file metadata, and the same values bit for bit, NaN where the reference has NaN
    (pyarrow's Table.equals treats NaN as unequal to itself)."""
    table, expected = pq.read_table(path), pq.read_table(reference)
    assert table.schema.equals(expected.schema, check_metadata=True), f"{path}: schema differs from {reference}"
    frame, expected_frame = table.to_pandas(), expected.to_pandas()
    assert list(frame.columns) == list(expected_frame.columns)
    for name in frame.columns:
        values, expected_values = frame[name].to_numpy(), expected_frame[name].to_numpy()
        if values.dtype.kind == "f":
            np.testing.assert_array_equal(values.view(np.int64), expected_values.view(np.int64),
                                          err_msg=f"{path}: column {name}")
        else:
            assert values.tolist() == expected_values.tolist(), f"{path}: column {name}"


def assert_same_study(folder: Path, reference: Path, exploration: Exploration) -> None:
    assert chunk_files(folder) == all_chunks(exploration)
    for model, chunk in sorted(all_chunks(exploration)):
        assert_same_chunk(chunk_path(folder, model, chunk), chunk_path(reference, model, chunk))
    assert manifest(folder) == manifest(reference)


def test_reference_study_has_unconverged_designs(exploration, serial_folder):
    """The study exercises NaN errors (designs not converged on some structure), so the comparisons below
    check NaN placement too; and every design of the sample is there once."""
    for model in exploration.models:
        rows = read_exploration(serial_folder, model)
        assert rows["design"].tolist() == list(range(exploration.sample.n_designs))
    converged = read_exploration(serial_folder, "jenkins")[[f"converged[{name}]" for name in exploration.names]]
    assert not converged.to_numpy().all()


KILLED_STUDY = """
import sys, time
sys.path[:0] = [{tests!r}, {helpers!r}]
import pyarrow.parquet as pq
from test_exploration import asb_exploration
from study.exploration import explore

write_table, writes = pq.write_table, []


def write_table_then_die(table, where, **options):
    # Write number {killed_at} stops half-way: its temporary file holds half a Parquet file when the test kills us.
    writes.append(where)
    write_table(table, where, **options)
    if len(writes) == {killed_at}:
        with open(where, "r+b") as handle:
            handle.truncate(handle.seek(0, 2) // 2)
        print("held", where, flush=True)
        time.sleep(600)


pq.write_table = write_table_then_die
explore(asb_exploration(), sys.argv[1], progress=False)
"""


def test_killed_study_resumes_without_losing_or_repeating_a_chunk(exploration, serial_folder, tmp_path,
                                                                   monkeypatch):
    """SIGKILL while a chunk's temporary file is half written: only whole chunks are visible (the temporary
    file is neither a chunk nor read), the rerun evaluates exactly the missing chunk files (of chunk 4 only
    iwan4's, whose task had written jenkins'), leaves the finished ones untouched (same inode, size and mtime),
    and the study equals an uninterrupted run."""
    script = tmp_path / "killed_study.py"
    script.write_text(KILLED_STUDY.format(tests=str(Path(__file__).parent), helpers=str(Path(__file__).parents[1]),
                                            killed_at=KILLED_AT_WRITE))
    folder, log = tmp_path / "study", tmp_path / "killed_study.log"
    with open(log, "w") as output:
        child = subprocess.Popen([sys.executable, str(script), str(folder)], cwd=REPOSITORY, stdout=output,
                                 stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while "held" not in log.read_text():
            if child.poll() is not None:
                pytest.fail(f"the study ended (exit {child.returncode}) before it could be killed:\n{log.read_text()}")
            if time.monotonic() > deadline:
                pytest.fail(f"the study wrote no {KILLED_AT_WRITE} chunks in {STARTUP_TIMEOUT_S} s:\n{log.read_text()}")
            time.sleep(0.05)
        os.kill(child.pid, signal.SIGKILL)
        assert child.wait(timeout=30) == -signal.SIGKILL
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()

    finished = chunk_files(folder)
    assert finished == {(model, chunk) for model in MODELS for chunk in range(4)} | {("jenkins", 4)}
    temporary = sorted(folder.glob("*/.partial-*"))
    assert [path.parent.name for path in temporary] == ["iwan4"]
    assert temporary[0].name.startswith(".partial-chunk-000004-")
    with pytest.raises(pa.ArrowInvalid):
        pq.read_table(temporary[0])  # half a file: the kill left it partial (the rerun sweeps it)
    assert finished_chunks(exploration, folder) == finished
    assert read_exploration(folder, "iwan4")["design"].tolist() == list(range(4 * exploration.sample.chunk_size))
    for model, chunk in finished:
        assert_same_chunk(chunk_path(folder, model, chunk), chunk_path(serial_folder, model, chunk))
    before = {name: identity for name, identity in file_identities(folder).items() if "/chunk-" in name}

    evaluated = []

    def recording(exploration, folder, chunk, models):
        evaluated.extend((model, chunk) for model in models)
        return evaluate(exploration, folder, chunk, models)

    evaluate = exploration_module.evaluate_chunk
    monkeypatch.setattr(exploration_module, "evaluate_chunk", recording)
    explore(exploration, folder, progress=False)

    assert sorted(evaluated) == sorted(all_chunks(exploration) - finished)  # each missing chunk once, no other
    assert not list(folder.rglob(".partial-*"))  # the killed run's temporary file swept
    after = file_identities(folder)
    assert {name: after[name] for name in before} == before
    assert_same_study(folder, serial_folder, exploration)


def test_models_evaluated_together_give_each_models_rows_alone(exploration, serial_folder, tmp_path, monkeypatch):
    """jenkins and iwan4 take K_T and K_z from the same columns of the sample, so a chunk's task forms the stuck
    modes once per structure (3 solves, not 6) for both; each model's rows are those of the model evaluated alone,
    bit for bit."""
    solves = []
    stuck_modes = condensation.stuck_modes
    monkeypatch.setattr(condensation, "stuck_modes", lambda *a, **k: solves.append(1) or stuck_modes(*a, **k))
    together = chunk_tables(exploration, 2)
    assert len(solves) == len(exploration.structures)
    names = parameter_names("jenkins", exploration.n_groups)
    for name in names:
        assert together["jenkins"][name].equals(together["iwan4"][name])
    for model in MODELS:
        alone = chunk_tables(exploration, 2, (model,))[model]
        write_chunk(alone, tmp_path / f"{model}.parquet", exploration.key())
        assert_same_chunk(tmp_path / f"{model}.parquet", chunk_path(serial_folder, model, 2))


def test_idle_fraction_is_the_threads_time_outside_the_chunks():
    """Two threads for 10 s that spent 6 s and 8 s in chunks were idle 6 s of their 20: 0.3."""
    timings = [ChunkTiming(("jenkins",), 0, "a:1", 100.0, 106.0), ChunkTiming(("jenkins",), 1, "b:2", 101.0, 109.0)]
    assert Explored([], timings, 10.0, 2).idle_fraction == pytest.approx(0.3, abs=1e-12)
    assert np.isnan(Explored([], [], 10.0, 2).idle_fraction)


def test_a_chunk_reported_but_not_in_the_folder_is_refused(exploration, tmp_path, monkeypatch):
    """A worker that wrote where this process cannot read (another machine's disk) is caught at once, naming
    the chunk's file and what the workers need."""
    monkeypatch.setattr(exploration_module, "evaluate_chunk",
                        lambda exploration, folder, chunk, models: ChunkTiming(models, chunk, "elsewhere:1", 0.0, 1.0))
    with pytest.raises(StudyError, match=r"chunk-000000\.parquet: the worker elsewhere:1 reported it written.*shared "
                                         r"file system"):
        explore(exploration, tmp_path / "study", progress=False)


@pytest.fixture
def local_cluster():
    """Two workers started as the study starts them (``pipeline.runners.local_cluster``)."""
    from distributed import Client

    with (runners.local_cluster(2, dashboard_address=None, silence_logs=logging.ERROR) as cluster,
          Client(cluster) as client):
        yield client


@pytest.fixture
def external_scheduler(tmp_path):
    """A `dask scheduler` and two `dask worker --nthreads 1` processes started from the venv's `dask`
    command, each in a session of its own; the finaliser ends every process of those sessions (the workers'
    nannies and their worker processes) even when the test fails."""
    from distributed import Client

    dask = Path(sys.executable).parent / "dask"
    scheduler_file = tmp_path / "scheduler.json"
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPOSITORY),
                                                                            os.environ.get("PYTHONPATH")]))}
    processes = []

    def start(*arguments):
        log = open(tmp_path / f"dask-{len(processes)}.log", "w")
        processes.append(subprocess.Popen([str(dask), *arguments], cwd=REPOSITORY, env=environment, stdout=log,
                                          stderr=subprocess.STDOUT, start_new_session=True))
        log.close()

    try:
        start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
              str(scheduler_file))
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while not scheduler_file.exists() or not scheduler_file.read_text().strip().endswith("}"):
            assert processes[0].poll() is None, (tmp_path / "dask-0.log").read_text()
            assert time.monotonic() < deadline, f"no scheduler file {scheduler_file} in {STARTUP_TIMEOUT_S} s"
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        for _ in range(2):
            start("worker", address, "--nthreads", "1", "--no-dashboard", "--death-timeout", "60")
        with Client(address, timeout=STARTUP_TIMEOUT_S) as client:
            client.wait_for_workers(2, timeout=STARTUP_TIMEOUT_S)
            yield client
    finally:
        for process in processes:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in processes:
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            try:  # a worker process its nanny left behind
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


@pytest.mark.parametrize("cluster", ["local_cluster", "external_scheduler"])
def test_cluster_writes_the_serial_rows(exploration, serial_folder, tmp_path, request, cluster):
    """A chunk's rows depend on its seed and inputs only: two worker processes (a LocalCluster, or an external
    scheduler with two `dask worker` processes) write the same floats, NaNs and metadata as the serial run,
    and the chunks were evaluated on the workers."""
    client = request.getfixturevalue(cluster)
    folder = tmp_path / "study"
    run = explore(exploration, folder, runners.Dask(client), progress=False)
    assert_same_study(folder, serial_folder, exploration)
    assert sorted((model, timing.chunk) for timing in run.timings for model in timing.models) == sorted(
        all_chunks(exploration))
    workers = {timing.worker for timing in run.timings}
    assert len(workers) == 2 and f"{socket.gethostname()}:{os.getpid()}" not in workers  # written by the workers
    assert run.threads == 2 and 0.0 <= run.idle_fraction < 1.0
    if cluster == "local_cluster":  # glibc's own trim threshold, not dask's eager one (8-10 % of the CPU time)
        assert set(client.run(lambda: os.environ.get("MALLOC_TRIM_THRESHOLD_")).values()) == {None}
    splits_formed = client.run(lambda: len(getattr(sys.modules.get("study.exploration"), "_SPLITS", {})))
    assert len(splits_formed) == 2 and sum(splits_formed.values()) >= 1


def test_same_study_twice_on_one_client(exploration, serial_folder, tmp_path, local_cluster):
    """A user re-running a study in one Dask session (a notebook, a script that explores twice): the second run
    scatters the same inputs and submits tasks of the same keys as the first, whose futures are being released;
    both runs write the serial rows."""
    for run in ("first", "second"):
        folder = tmp_path / run
        explore(exploration, folder, runners.Dask(local_cluster), progress=False)
        assert_same_study(folder, serial_folder, exploration)


def other_parquet_reader():
    """(name, read) of a Parquet reader other than pyarrow: read(path) gives the columns as numpy arrays, each
    column's kind ('integer', 'float', 'bool', 'string') and the file's key-value metadata. DuckDB, else
    Polars, else fastparquet; the test skips where none is installed."""
    try:
        import duckdb
    except ImportError:
        pass
    else:
        def read_duckdb(path):
            connection = duckdb.connect()
            source = f"read_parquet('{path}')"
            kinds = {"BIGINT": "integer", "INTEGER": "integer", "SMALLINT": "integer", "DOUBLE": "float",
                     "BOOLEAN": "bool", "VARCHAR": "string"}
            types = {row[0]: kinds.get(row[1], row[1]) for row in connection.sql(f"DESCRIBE SELECT * FROM {source}")
                     .fetchall()}
            columns = connection.sql(f"SELECT * FROM {source}").fetchnumpy()
            metadata = dict(connection.sql(f"SELECT key, value FROM parquet_kv_metadata('{path}')").fetchall())
            return {name: np.asarray(values) for name, values in columns.items()}, types, metadata
        return "duckdb", read_duckdb
    try:
        import polars
    except ImportError:
        pass
    else:
        def read_polars(path):
            frame = polars.read_parquet(path, use_pyarrow=False)
            types = {name: "integer" if dtype.is_integer() else "float" if dtype.is_float() else
                     "bool" if dtype == polars.Boolean else "string" if dtype in (polars.String, polars.Categorical)
                     else str(dtype) for name, dtype in frame.schema.items()}
            metadata = {key.encode(): value.encode() for key, value in polars.read_parquet_metadata(path).items()}
            return {name: frame[name].cast(polars.String).to_numpy() if types[name] == "string"
                    else frame[name].to_numpy() for name in frame.columns}, types, metadata
        return "polars", read_polars
    try:
        import fastparquet
    except ImportError:
        pytest.skip("no Parquet reader other than pyarrow installed (duckdb, polars or fastparquet)")

    def read_fastparquet(path):
        file = fastparquet.ParquetFile(str(path))
        frame = file.to_pandas()
        kinds = {"i": "integer", "f": "float", "b": "bool", "O": "string"}
        types = {name: "string" if str(dtype) == "category" else kinds.get(dtype.kind, str(dtype))
                 for name, dtype in frame.dtypes.items()}
        metadata = {key.encode(): value.encode() for key, value in file.key_value_metadata.items()}
        return {name: frame[name].astype(object if types[name] == "string" else frame[name].dtype).to_numpy()
                for name in frame.columns}, types, metadata
    return "fastparquet", read_fastparquet


def documented_columns(exploration: Exploration, model: str) -> dict[str, str]:
    """Column name -> kind, as the study.exploration module docstring documents the row of a design."""
    columns = {"model": "string", "design": "integer", "chunk": "integer", "replicate": "integer",
               "seed": "integer"}
    columns.update({name: "float" for name in parameter_names(model, exploration.n_groups)})
    for name in exploration.names:
        columns[f"frequency_error_hz[{name}]"] = "float"
        columns.update({f"damping_error[{name}][{case}]": "float" for case in exploration.damping_cases})
        columns[f"converged[{name}]"] = "bool"
        columns[f"reason[{name}]"] = "string"
        columns[f"stuck_frequency_hz[{name}]"] = "float"
    return columns


def test_chunks_read_by_another_parquet_reader(exploration, serial_folder):
    """Another reader than pyarrow sees the documented columns in order with their kinds, the values pyarrow
    reads (NaN where pyarrow has NaN), and the study key and seed in the file's metadata."""
    name, read = other_parquet_reader()
    for model, chunk in sorted(all_chunks(exploration)):
        path = chunk_path(serial_folder, model, chunk)
        columns, types, metadata = read(path)
        assert types == documented_columns(exploration, model), f"{name}: {path}"
        assert list(types) == list(documented_columns(exploration, model)), f"{name}: {path}: column order"
        assert metadata[b"study_key"].decode() == exploration.key() == manifest(serial_folder)["study_key"]
        assert metadata[b"seed"].decode() == str(exploration.sample.seed)
        expected = pq.read_table(path).to_pandas()
        for column, values in columns.items():
            if types[column] == "string":
                assert values.tolist() == expected[column].astype(str).tolist(), f"{name}: {path}: {column}"
            else:
                np.testing.assert_array_equal(values, expected[column].to_numpy(), err_msg=f"{name}: {path}: {column}")
        assert columns["design"].tolist() == list(range(chunk * exploration.sample.chunk_size,
                                                       (chunk + 1) * exploration.sample.chunk_size))


@pytest.mark.parametrize("difference", ["seed", "damping case", "levels"])
def test_folder_of_another_study_is_refused(exploration, serial_folder, tmp_path, difference):
    """A study whose sample, zeta_0 cases or measured levels differ refuses the folder, naming the first chunk
    file, and writes nothing (not even its manifest)."""
    folder = tmp_path / "study"
    shutil.copytree(serial_folder, folder)
    before = file_identities(folder)
    other = {"seed": lambda: replace(exploration, sample=replace(exploration.sample, seed=12)),
             "damping case": lambda: replace(exploration, damping_cases={**DAMPING_CASES, "high": (1e-3,) * 3}),
             "levels": lambda: asb_exploration(n_levels=N_LEVELS - 1)}[difference]()
    assert other.key() != exploration.key()
    with pytest.raises(StudyError, match=re.escape(str(chunk_path(folder, MODELS[0], 0)))):
        explore(other, folder, progress=False)
    assert file_identities(folder) == before


def test_second_run_into_a_busy_folder_is_refused(exploration, tmp_path):
    """While one run holds a study folder, a second explore into it is refused (FolderBusyError naming the
    folder) and writes nothing; once the first is done the folder is free again."""
    import fcntl

    from pipeline.files import FolderBusyError

    folder = tmp_path / "busy"
    folder.mkdir()
    with open(folder / ".lock", "a") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(FolderBusyError, match=str(folder)):
            explore(exploration, folder, progress=False)
        assert sorted(path.name for path in folder.iterdir()) == [".lock"]
        fcntl.flock(holder, fcntl.LOCK_UN)
    explore(exploration, folder, progress=False)
    assert finished_chunks(exploration, folder) == all_chunks(exploration)


def test_restart_stale_discards_only_another_studys_chunks(exploration, serial_folder, tmp_path):
    """With restart_stale, the chunks of another study (other seed) are discarded and recomputed; the result is
    the study's own serial rows."""
    import dataclasses
    import shutil

    folder = tmp_path / "restart"
    shutil.copytree(serial_folder, folder)
    other = dataclasses.replace(exploration, sample=dataclasses.replace(exploration.sample, seed=12))
    with pytest.raises(StudyError, match="--restart-stale"):
        explore(other, folder, progress=False)
    explore(other, folder, progress=False, restart_stale=True)
    assert finished_chunks(other, folder) == all_chunks(other)
    explore(exploration, folder, progress=False, restart_stale=True)
    assert_same_study(folder, serial_folder, exploration)


def test_truncated_chunk_is_recomputed_naming_it(exploration, serial_folder, tmp_path, capsys):
    """A chunk file cut short (a disk that filled up, a copy that stopped) is refused by the analysis' check and
    its readers, naming it, then removed and recomputed by the next exploration, which names it on stderr; the
    study is then the serial one."""
    folder = tmp_path / "truncated"
    shutil.copytree(serial_folder, folder)
    path = chunk_path(folder, MODELS[1], 3)
    path.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(StudyError, match=re.escape(f"{path}: not a readable Parquet chunk")):
        check_explored(exploration, folder)
    with pytest.raises(StudyError, match=re.escape(f"{path}: not a readable chunk of the study")):
        read_exploration(folder, MODELS[1])
    explore(exploration, folder, progress=False)
    assert f"{path}: not a readable Parquet chunk (truncated?): removed, recomputing" in capsys.readouterr().err
    assert_same_study(folder, serial_folder, exploration)
    check_explored(exploration, folder)


@pytest.mark.parametrize("damage", ["copy of another chunk", "fewer rows", "another model's chunk", "edited parameter"])
def test_a_chunk_that_is_not_its_seeds_designs_is_refused_then_recomputed(exploration, serial_folder, tmp_path, capsys,
                                                                        damage):
    """A chunk of this study's key whose rows are not the designs its seed regenerates (chunk 3 of jenkins, designs
    90-119: a copy of chunk 2, rewritten with its first 15 rows, a copy of iwan4's chunk 3, or one parameter x 1.01)
    is refused by the analysis' check naming the file and the first difference, with no file changed; the next
    exploration names it on stderr, discards and recomputes it, and the study is then the serial one."""
    folder = tmp_path / "damaged"
    shutil.copytree(serial_folder, folder)
    path = chunk_path(folder, MODELS[0], 3)
    name = parameter_names(MODELS[0], exploration.n_groups)[0]
    table = pq.read_table(path)
    if damage == "copy of another chunk":
        shutil.copy(chunk_path(folder, MODELS[0], 2), path)
        expected = "row 0 holds design 60, expected designs 90 to 119"
    elif damage == "fewer rows":
        pq.write_table(table.slice(0, 15), path)
        expected = "15 row(s), expected the 30 designs 90 to 119"
    elif damage == "another model's chunk":
        shutil.copy(chunk_path(folder, MODELS[1], 3), path)
        expected = f"rows of model {MODELS[1]!r}, expected {MODELS[0]!r}"
    else:
        values = table[name].to_numpy().copy()
        values[5] *= 1.01
        pq.write_table(table.set_column(table.schema.get_field_index(name), name, pa.array(values)), path)
        expected = f"design 95: {name} = {values[5]:.9g}, the seed gives {values[5] / 1.01:.9g}"
    assert pq.read_schema(path).metadata[b"study_key"] == exploration.key().encode()
    before = file_contents(folder)
    with pytest.raises(StudyError) as refused:
        check_explored(exploration, folder)
    assert str(refused.value) == (f"{path}: not the designs its seed regenerates ({expected}); run the explore step, "
                                  "which discards and recomputes it (--steps explore analyse)")
    assert file_contents(folder) == before
    capsys.readouterr()
    explore(exploration, folder, progress=False)
    assert capsys.readouterr().err.splitlines() == [
        f"{path}: not the designs its seed regenerates ({expected}): removed, recomputing"]
    assert_same_study(folder, serial_folder, exploration)
    check_explored(exploration, folder)


@pytest.mark.parametrize("change", ["deleted chunk", "extra chunk", "other inputs"])
def test_analysis_refuses_a_folder_that_is_not_this_studys_exploration(exploration, serial_folder, tmp_path, change):
    """``check_explored``, the analysis' check: a deleted chunk, a chunk beyond the sample, or an exploration of
    other inputs (another zeta_0 case) is refused naming the file; the serial folder itself passes."""
    check_explored(exploration, serial_folder)
    folder = tmp_path / "changed"
    shutil.copytree(serial_folder, folder)
    analysed = exploration
    if change == "deleted chunk":
        named = chunk_path(folder, MODELS[0], 5)
        named.unlink()
    elif change == "extra chunk":
        named = chunk_path(folder, MODELS[0], SAMPLE.n_chunks)
        shutil.copy(chunk_path(folder, MODELS[0], 0), named)
    else:
        named = folder / "exploration.json"
        analysed = replace(exploration, damping_cases={**DAMPING_CASES, "high": (1e-3,) * 3})
    with pytest.raises(StudyError, match=re.escape(str(named))):
        check_explored(analysed, folder)


def asb_study_arguments(out: Path, *steps: str) -> list[str]:
    """``surrogacy study`` on the ASB with Jenkins and 4 designs in 2 chunks (a few seconds)."""
    return ["study", "--out", str(out), "--data", str(ASB_MODELS.parent),
            "--reference", str(REPOSITORY.parent / "shared" / "reference"), "--set", "study.dataset=asb",
            "--set", 'study.models=["jenkins"]', "--set", "sample.n_designs=4", "--set", "sample.chunk_size=2",
            "--steps", *steps]


@pytest.fixture(scope="module")
def asb_cli_study(exploration, tmp_path_factory) -> Path:
    """A tiny ASB study's measurements and exploration, written by the ``surrogacy study`` command."""
    from cli.console import main as surrogacy

    folder = tmp_path_factory.mktemp("asb_cli") / "study"
    assert surrogacy(asb_study_arguments(folder, "measurements", "explore")) == 0
    return folder


def scale_frequencies(path: Path, factor: float) -> None:
    """Multiply the natural_frequency column of a backbone CSV by ``factor``."""
    lines = path.read_text().splitlines()
    for index, line in enumerate(lines):
        if line[:1].isdigit():
            cells = line.split(",")
            cells[1] = repr(float(cells[1]) * factor)
            lines[index] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("change, named, expected", [
    ("deleted chunk", "designs/jenkins/chunk-000001.parquet", "missing (1 of the 2 chunks of jenkins)"),
    ("truncated chunk", "designs/jenkins/chunk-000001.parquet", "not a readable Parquet chunk"),
    ("copied chunk", "designs/jenkins/chunk-000001.parquet",
     "not the designs its seed regenerates (row 0 holds design 0, expected designs 2 to 3)"),
    ("halved chunk", "designs/jenkins/chunk-000001.parquet",
     "not the designs its seed regenerates (1 row(s), expected the 2 designs 2 to 3)"),
    ("edited measurement", "designs/exploration.json", "explored for other inputs"),
], ids=["deleted chunk", "truncated chunk", "copied chunk", "halved chunk", "edited measurement"])
def test_analyse_step_refuses_inputs_the_exploration_did_not_use(asb_cli_study, tmp_path, capsys, change, named,
                                                                 expected):
    """``surrogacy study --steps analyse`` after a chunk was deleted, cut short, overwritten by a copy of chunk 0 or
    rewritten as valid Parquet with its first row only, or after a measurement was edited (frequencies x 1.05):
    exit 2, one line naming the file, what differs and what to run; no file changed, no analysis written, with
    ``--restart-stale`` too. ``--steps explore`` then recomputes the chunk as it was (a few seconds each)."""
    from cli.console import main as surrogacy

    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    chunk = folder / "designs" / "jenkins" / "chunk-000001.parquet"
    if change == "deleted chunk":
        chunk.unlink()
    elif change == "truncated chunk":
        chunk.write_bytes(chunk.read_bytes()[:500])
    elif change == "copied chunk":
        shutil.copy(folder / "designs" / "jenkins" / "chunk-000000.parquet", chunk)
    elif change == "halved chunk":
        pq.write_table(pq.read_table(chunk).slice(0, 1), chunk)
    else:
        scale_frequencies(folder / "measurements" / "ASB_C1.csv", 1.05)
    before = file_contents(folder)
    capsys.readouterr()
    assert surrogacy(asb_study_arguments(folder, "analyse")) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{folder / named}: {expected}" in lines[0] and "--steps explore analyse" in lines[0]
    assert file_contents(folder) == before and not (folder / "analysis").exists()
    assert surrogacy([*asb_study_arguments(folder, "analyse"), "--restart-stale"]) == 2  # analyse recomputes nothing
    assert f"{folder / named}: {expected}" in capsys.readouterr().err and file_contents(folder) == before
    if change != "edited measurement":
        assert surrogacy(asb_study_arguments(folder, "explore")) == 0
        assert_same_chunk(chunk, asb_cli_study / "designs" / "jenkins" / "chunk-000001.parquet")


def test_compute_device_cuda_explores_the_same_rows_in_the_simulator(asb_cli_study, tmp_path):
    """``--set compute.device=cuda``: the explore step forms every structure's stuck modes and solves its levels
    of every chunk by the CUDA path (``qsma_designs(device="cuda")``), here numba-cuda's simulator
    (NUMBA_ENABLE_CUDASIM=1 in the command's process), and writes the rows the CPU wrote: the same designs, flags
    and reasons, the errors within 1e-10 of the CPU's (the device's round-off is not the CPU's on a GPU; in the
    simulator it is)."""
    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    shutil.rmtree(folder / "designs")
    calls = device_calls([*asb_study_arguments(folder, "explore"), "--set", "compute.device=cuda"], "simulated")
    # the six ASB configurations x 2 chunks, each kernel
    assert calls == {"cuda stuck_designs": 12, "cuda solve_levels": 12, "cpu stuck_designs": 0, "cpu solve_levels": 0}
    assert json.loads((folder / "study.json").read_text())["configuration"]["compute"] == {"device": "cuda"}
    for chunk in (0, 1):
        cuda, cpu = (pq.read_table(chunk_path(root / "designs", "jenkins", chunk)).to_pandas()
                     for root in (folder, asb_cli_study))
        assert list(cuda.columns) == list(cpu.columns)
        for name in cpu.columns:
            if cpu[name].dtype.kind == "f":
                np.testing.assert_allclose(cuda[name], cpu[name], rtol=1e-10, atol=0.0, err_msg=name)
            else:
                assert cuda[name].tolist() == cpu[name].tolist(), name


@pytest.mark.parametrize("steps", [["measurements", "explore"], ["analyse"]])
def test_a_cuda_study_where_numba_cuda_finds_no_gpu_is_refused_before_any_step(tmp_path, capsys, steps):
    """``--set compute.device=cuda`` on a machine without a GPU, with a step that evaluates designs here: exit 2
    with one line naming the setting and what is missing, and no folder made."""
    from numba import cuda

    from cli.console import main as surrogacy

    if cuda.is_available():
        pytest.skip("numba-cuda finds a GPU (or its simulator) here: cuda can run")
    folder = tmp_path / "study"
    assert surrogacy([*asb_study_arguments(folder, *steps), "--set", "compute.device=cuda"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "[compute] device" in error[0] and "no usable CUDA GPU" in error[0], error
    assert not folder.exists()


def test_study_of_another_dataset_is_refused_before_any_step(asb_cli_study, tmp_path, capsys):
    """A beams study into an ASB study's folder: exit 2 at once, one line naming the file that records the ASB
    dataset, and the folder untouched (no virtual experiment run, no measurement file added)."""
    from cli.console import main as surrogacy

    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    before = file_identities(folder)
    capsys.readouterr()
    started = time.perf_counter()
    assert surrogacy(["study", "--out", str(folder), "--rom", str(tmp_path / "rom"), "--steps", "measurements"]) == 2
    assert time.perf_counter() - started < 5.0
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"surrogacy study: error: {folder / 'study.json'}: a study of the 'asb' dataset; expected "
                     "'beams' here (give the beams study another --out)"]
    assert file_identities(folder) == before


@pytest.mark.parametrize("setting", ["sample.seed=7", "sample.n_designs=6"])
def test_study_refused_for_another_studys_chunks_changes_no_file(asb_cli_study, tmp_path, capsys, setting):
    """Every step again into a study's folder with another seed or sample size: exit 2, one line naming the first
    chunk as written by another study, and every file byte for byte as it was (study.json keeps the study's own
    configuration, so the report's provenance stays true)."""
    from cli.console import main as surrogacy

    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    before = file_contents(folder)
    capsys.readouterr()
    assert surrogacy([*asb_study_arguments(folder, "measurements", "explore", "analyse", "report"),
                      "--set", setting]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"surrogacy study: error: {folder / 'designs' / 'jenkins' / 'chunk-000000.parquet'}: written by another "
        "study (study_key ") and lines[0].endswith("use another results folder, or discard them with --restart-stale")
    assert file_contents(folder) == before


def test_full_disk_while_a_chunk_is_written_names_the_chunk(asb_cli_study, tmp_path, capsys, monkeypatch):
    """The disk fills up while a chunk is written (pyarrow's OSError names no file): exit 2, one line naming the
    chunk and the errno, no temporary left, and the next run computes the chunk."""
    from cli.console import main as surrogacy

    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    chunk = folder / "designs" / "jenkins" / "chunk-000001.parquet"
    chunk.unlink()

    def full_disk(table, where, **options):
        Path(where).write_bytes(b"PAR1")
        raise OSError(28, "Error writing bytes to file. Detail: [errno 28] No space left on device")

    monkeypatch.setattr(exploration_module.pq, "write_table", full_disk)
    capsys.readouterr()
    assert surrogacy(asb_study_arguments(folder, "explore")) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if "%|" not in line and line.strip()]
    assert len(lines) == 1 and f"{chunk}: [Errno 28] Error writing bytes" in lines[0], lines
    assert not list(folder.rglob(".partial-*")) and not chunk.exists()
    monkeypatch.undo()
    assert surrogacy(asb_study_arguments(folder, "explore")) == 0
    assert_same_chunk(chunk, asb_cli_study / "designs" / "jenkins" / "chunk-000001.parquet")


def test_negative_damping_in_a_measurement_is_refused_by_the_study(asb_cli_study, tmp_path, capsys):
    """A measurement file with a negative damping ratio (it was accepted): the explore step ends with exit 2 and
    one line naming the file and the field, and writes no chunk."""
    from cli.console import main as surrogacy

    folder = tmp_path / "study"
    shutil.copytree(asb_cli_study, folder)
    shutil.rmtree(folder / "designs")
    measurement = folder / "measurements" / "ASB_C2.csv"
    lines = measurement.read_text().splitlines()
    row = next(index for index, line in enumerate(lines) if line[:1].isdigit())
    cells = lines[row].split(",")
    cells[4] = "-0.0003"
    lines[row] = ",".join(cells)
    measurement.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert surrogacy(asb_study_arguments(folder, "explore")) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"surrogacy study: error: {measurement}: field damping_ratio: 1 value(s) out of range, the first -0.0003 "
        "(expected non-negative ratios (fraction of critical) at every point)"]
    assert not list((folder / "designs").rglob("*.parquet"))
