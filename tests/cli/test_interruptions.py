"""Stages after an interruption and beside a concurrent run: the temporaries a killed run
left are swept when the stage next runs, Ctrl-C ends a stage with exit 130 and no traceback, a rerun after any
interruption gives the files of an uninterrupted run without recomputing the beams already finished, and a second
run into a folder another run is writing is refused with one line naming the folder (exit 2), touching nothing.

The kill tests run ``surrogacy`` as real processes on coarse beams and signal them at points found by watching the
output folder: while the first beam is computed (half a second after the stage took its folder's lock), while its
files are written (a ``.partial-*`` temporary exists) and once its sidecar is in place (the second beam then
computing).
"""

import argparse
import errno
import fcntl
import json
import os
import re
import shutil
import signal
import sys
import time

import pytest

from cli.console import main as surrogacy
from cli.console import run, stage_signals
from pipeline.files import LOCK, OutputFolderError, atomic_path
from stage_runs import COARSE, digests, partial_files, run_to_end, start, wait_for

BEAMS = ["BRB", "LBRB"]
INTERRUPTED = "interrupted; finished results are kept, rerun to go on"  # the console script's line for Ctrl-C


@pytest.fixture(scope="module")
def coarse_beams(tmp_path_factory):
    """Coarse BRB and LBRB meshes from the geometry stage, shared by every test of the module."""
    folder = tmp_path_factory.mktemp("coarse_beams")
    assert surrogacy(["beams", "--beam", *BEAMS, "--no-render", "--out", str(folder), *COARSE]) == 0
    return folder


@pytest.fixture(scope="module")
def fe_brb(coarse_beams, tmp_path_factory):
    """The reference: the FE stage's output for the BRB from one uninterrupted run (about 15 s)."""
    folder = tmp_path_factory.mktemp("fe_brb")
    arguments = ["fe", "--beam", "BRB", "--beams", str(coarse_beams), "--out", str(folder / "fe")]
    assert run_to_end(arguments, folder / "run.log") == 0
    return folder / "fe"


@pytest.fixture(scope="module")
def fe_pair(coarse_beams, fe_brb, tmp_path_factory):
    """The reference for both beams: the BRB's reference files, then an uninterrupted run for BRB and LBRB (which
    finds the BRB current and computes the LBRB)."""
    folder = tmp_path_factory.mktemp("fe_pair")
    shutil.copytree(fe_brb, folder / "fe")
    arguments = ["fe", "--beam", *BEAMS, "--beams", str(coarse_beams), "--out", str(folder / "fe")]
    assert run_to_end(arguments, folder / "run.log") == 0
    return folder / "fe"


@pytest.fixture(scope="module")
def rom_pair(coarse_beams, fe_pair, tmp_path_factory):
    """The reduction stage's output for both beams from one uninterrupted run."""
    folder = tmp_path_factory.mktemp("rom_pair")
    arguments = ["rom", "--beam", *BEAMS, "--beams", str(coarse_beams), "--fe", str(fe_pair),
                 "--out", str(folder / "rom")]
    assert run_to_end(arguments, folder / "run.log") == 0
    return folder / "rom"


def interrupt_at(point: str, process, out) -> None:
    """Wait until the run started into ``out`` reaches ``point`` (module docstring)."""
    if point == "computing":
        wait_for(lambda: (out / LOCK).exists(), process, "the stage's lock")
        time.sleep(0.5)
        assert not partial_files(out), "the run was writing its first beam half a second after taking its lock"
    elif point == "writing":
        wait_for(lambda: partial_files(out), process, "a temporary file")
    else:
        wait_for(lambda: (out / "BRB.json").exists(), process, "the BRB's sidecar")


def assert_clean_ctrl_c(status: int, log) -> None:
    """Exit 130, the CLI's one line last, no traceback."""
    error = log.read_text()
    assert status == 130, error
    assert "Traceback" not in error and INTERRUPTED in error.strip().splitlines()[-1]


def stamps(folder, beam: str) -> dict:
    """(inode, mtime in ns) of each output file of ``beam``: an atomic rewrite changes both."""
    return {path.name: (path.stat().st_ino, path.stat().st_mtime_ns) for path in sorted(folder.glob(f"{beam}*"))}


KILLS = [pytest.param("fe", "SIGINT", "computing", ["BRB"], id="fe-SIGINT-computing-BRB"),
         *(pytest.param(stage, kill, point, BEAMS, marks=pytest.mark.slow, id=f"{stage}-{kill}-{point}")
           for stage in ("fe", "rom") for kill in ("SIGKILL", "SIGINT") for point in ("computing", "writing", "done"))]


@pytest.mark.parametrize("stage, kill, point, beams", KILLS)
def test_rerun_after_a_kill_gives_the_uninterrupted_files(request, coarse_beams, tmp_path, stage, kill, point, beams):
    """SIGKILL or Ctrl-C at one point of a run of fe or rom, then a rerun: exit 130 and no temporaries after
    Ctrl-C, the files of an uninterrupted run byte for byte (every array of every .npz) after the rerun, no
    temporaries, and the BRB untouched where it had finished before the kill. The default run keeps one case (fe on
    the BRB alone, Ctrl-C while computing: about 20 s); the others, on the BRB and LBRB, are slow (fe 50-60 s,
    rom 20-40 s each; all twelve about 9 minutes on a busy 2-core machine)."""
    out = tmp_path / stage
    if stage == "fe":
        reference = request.getfixturevalue("fe_brb" if beams == ["BRB"] else "fe_pair")
        arguments = ["fe", "--beam", *beams, "--beams", str(coarse_beams), "--out", str(out)]
    else:
        reference = request.getfixturevalue("rom_pair")
        arguments = ["rom", "--beam", *beams, "--beams", str(coarse_beams), "--fe",
                     str(request.getfixturevalue("fe_pair")), "--out", str(out)]
    process = start(arguments, tmp_path / "interrupted.log")
    interrupt_at(point, process, out)
    process.send_signal(getattr(signal, kill))
    status = process.wait(timeout=120)
    if kill == "SIGKILL":
        assert status == -signal.SIGKILL
        assert bool(partial_files(out)) == (point == "writing")  # the litter the rerun has to sweep
    else:
        assert_clean_ctrl_c(status, tmp_path / "interrupted.log")
        assert not partial_files(out)
    finished = stamps(out, "BRB") if point == "done" else {}
    assert (out / "BRB.json").exists() == (point == "done") and not (out / "LBRB.json").exists()

    assert run_to_end(arguments, tmp_path / "rerun.log") == 0
    assert not partial_files(out)
    assert digests(out) == digests(reference)
    if point == "done":
        assert stamps(out, "BRB") == finished


@pytest.mark.parametrize("point", ["writing", pytest.param("done", marks=pytest.mark.slow)])
def test_ctrl_c_after_gmsh_started_is_a_clean_exit(tmp_path, point):
    """gmsh.initialize() used to reset SIGINT to the default action: Ctrl-C once a beam was meshing or meshed
    killed the process outright (no exit 130, temporaries left). Ctrl-C while the BRB is meshed and rendered, or
    once it is done (the LBRB then meshing), now ends with exit 130, no traceback, no temporaries, and the BRB's
    files kept when finished (about 10 s each)."""
    out = tmp_path / "beams"
    process = start(["beams", "--beam", *BEAMS, "--out", str(out), *COARSE], tmp_path / "beams.log")
    interrupt_at(point, process, out)
    process.send_signal(signal.SIGINT)
    assert_clean_ctrl_c(process.wait(timeout=120), tmp_path / "beams.log")
    assert not partial_files(out)
    finished = {".lock", "BRB.json", "BRB.msh", "BRB.vtu", "BRB.png"} if point == "done" else {".lock"}
    assert {path.name for path in out.iterdir()} == finished


def test_sigterm_after_gmsh_started_is_a_clean_exit(tmp_path):
    """gmsh's library resets SIGTERM to the default action as it initialises: a SIGTERM once a beam was meshing
    killed the process outright (temporaries left, no run log line). SIGTERM while the BRB's files are written now
    ends with exit 143, no traceback, no temporaries, and the run logged with its status (about 10 s)."""
    out, run_log = tmp_path / "beams", tmp_path / "runs.jsonl"
    process = start(["--run-log", str(run_log), "beams", "--beam", *BEAMS, "--out", str(out), *COARSE],
                    tmp_path / "beams.log")
    interrupt_at("writing", process, out)
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=120) == 128 + signal.SIGTERM
    assert "Traceback" not in (tmp_path / "beams.log").read_text()
    assert not partial_files(out)
    assert {path.name for path in out.iterdir()} == {".lock"}
    assert json.loads(run_log.read_text())["status"] == 128 + signal.SIGTERM


@pytest.mark.slow
@pytest.mark.parametrize("stage", ["fe", "rom"])
def test_sigterm_while_fe_or_rom_writes_is_a_clean_exit(request, coarse_beams, tmp_path, stage):
    """fe and rom read the beams' meshes through gmsh, which reset SIGTERM likewise: SIGTERM while the BRB's files
    are written now ends with exit 143, no temporaries, and the run logged with its status (both about 35 s on a
    busy 2-core machine, the coarse beams and fe fixtures included)."""
    out, run_log = tmp_path / stage, tmp_path / "runs.jsonl"
    arguments = [stage, "--beam", *BEAMS, "--beams", str(coarse_beams), "--out", str(out)]
    if stage == "rom":
        arguments += ["--fe", str(request.getfixturevalue("fe_pair"))]
    process = start(["--run-log", str(run_log), *arguments], tmp_path / "stage.log")
    interrupt_at("writing", process, out)
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=120) == 128 + signal.SIGTERM
    assert "Traceback" not in (tmp_path / "stage.log").read_text()
    assert not partial_files(out) and not (out / "BRB.json").exists()
    assert json.loads(run_log.read_text())["status"] == 128 + signal.SIGTERM


def test_ctrl_c_while_the_stages_load_is_a_clean_exit(tmp_path):
    """Ctrl-C half a second after ``surrogacy`` starts, while it imports the stages: exit 130 and no traceback."""
    process = start(["beams", "--beam", "BRB", "--no-render", "--out", str(tmp_path / "beams"), *COARSE],
                    tmp_path / "beams.log")
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)
    assert_clean_ctrl_c(process.wait(timeout=60), tmp_path / "beams.log")


class SignalInFinaliser:
    """An object whose finaliser receives a signal: Python ignores the exception that the handler raises there (a
    KeyboardInterrupt or SystemExit), as it does in its import machinery's callbacks."""

    def __init__(self, signal_number: int):
        self.signal_number = signal_number

    def __del__(self):
        os.kill(os.getpid(), self.signal_number)
        time.sleep(0.1)  # the handler runs here, inside the finaliser


@pytest.mark.parametrize("signal_number, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["ctrl-c", "sigterm"])
def test_a_signal_that_python_swallows_still_stops_the_stage_at_once(signal_number, status, capsys):
    """Ctrl-C or SIGTERM whose exception Python swallows (raised in a finaliser) is delivered again once the
    finaliser has returned: the stage stops within a second instead of running on to its end, exit 130 (with the
    interrupted line) or 143, nothing printed about the finaliser; the previous handlers and hook are back after."""
    def stage(arguments):
        SignalInFinaliser(signal_number)  # made and finalised at once
        time.sleep(5.0)  # the rest of the stage's work
        arguments.reached_the_end = True

    arguments = argparse.Namespace(command="beams", run=stage, reached_the_end=False)
    before = signal.getsignal(signal_number), sys.unraisablehook
    started = time.monotonic()
    with stage_signals():
        assert exit_status(arguments) == status
    assert not arguments.reached_the_end and time.monotonic() - started < 1.0
    error = capsys.readouterr().err
    assert "Exception ignored" not in error and "Traceback" not in error
    assert (INTERRUPTED in error) == (signal_number == signal.SIGINT)
    assert (signal.getsignal(signal_number), sys.unraisablehook) == before


def stage_whose_extension_mangles(signal_number):
    """A stage that receives ``signal_number`` inside a C extension which returns another exception in its place, as
    numba's dispatcher does when Ctrl-C comes while it compiles (SystemError "returned a result with an exception
    set"; seen in ``make demo``'s ASB study); without a signal, the same SystemError is a bug."""
    def stage(arguments):
        try:
            if signal_number is not None:
                os.kill(os.getpid(), signal_number)
                time.sleep(0.1)  # the handler runs here
        except BaseException as error:
            raise SystemError("CPUDispatcher returned a result with an exception set") from error
        raise SystemError("returned a result with an exception set")
    return stage


def exit_status(arguments) -> int:
    """``run``'s status, or the code of the SystemExit it raises (SIGTERM)."""
    try:
        return run(arguments)
    except SystemExit as stop:
        return stop.code


@pytest.mark.parametrize("signal_number, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["ctrl-c", "sigterm"])
def test_an_exception_that_stands_for_the_interruption_ends_the_stage_cleanly(signal_number, status, capsys):
    """After Ctrl-C any exception ends the stage with 130 and the interrupted line, after SIGTERM with 143; no
    traceback either way."""
    arguments = argparse.Namespace(command="study", run=stage_whose_extension_mangles(signal_number))
    with stage_signals():
        assert exit_status(arguments) == status
    assert (INTERRUPTED in capsys.readouterr().err) == (signal_number == signal.SIGINT)


def test_the_same_exception_with_no_signal_is_a_bug():
    """With no Ctrl-C or SIGTERM, the SystemError escapes ``run``: a traceback and exit 1."""
    with stage_signals(), pytest.raises(SystemError):
        run(argparse.Namespace(command="study", run=stage_whose_extension_mangles(None)))


def test_two_identical_fe_runs_at_once_compute_once(coarse_beams, fe_brb, tmp_path):
    """Two identical ``surrogacy fe`` started together into one folder: one computes, the other is refused with
    exit 2 and one line naming the folder; the folder then holds the files of a single run, byte for byte
    (about 20 s)."""
    out = tmp_path / "fe"
    arguments = ["fe", "--beam", "BRB", "--beams", str(coarse_beams), "--out", str(out)]
    logs = [tmp_path / f"run_{k}.log" for k in (1, 2)]
    processes = [start(arguments, log) for log in logs]
    statuses = [process.wait(timeout=600) for process in processes]
    assert sorted(statuses) == [0, 2]
    refused = logs[statuses.index(2)].read_text().strip().splitlines()
    assert len(refused) == 1 and f"{out}: another run is writing here" in refused[0]
    assert not partial_files(out)
    assert digests(out) == digests(fe_brb)


def test_stage_sweeps_what_a_killed_run_left(tmp_path):
    out = tmp_path / "beams"
    out.mkdir()
    leftover = out / ".partial-BRB-k1ll3d.msh"  # the name atomic_path gives a temporary; SIGKILL leaves it
    leftover.write_bytes(b"half a mesh")
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(out), *COARSE]) == 0
    assert not leftover.exists()
    assert not list(out.rglob(".partial-*"))
    assert (out / "BRB.msh").exists() and (out / "BRB.json").exists()


def test_second_run_into_a_busy_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "beams"
    out.mkdir()
    with open(out / ".lock", "a") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(out), *COARSE]) == 2
    error = capsys.readouterr().err
    assert str(out) in error and "another run is writing here" in error
    assert sorted(path.name for path in out.iterdir()) == [".lock"]


def test_output_folder_that_is_a_file_is_one_line(tmp_path, capsys):
    out = tmp_path / "a_file"
    out.write_text("not a folder")
    assert surrogacy(["beams", "--beam", "BRB", "--no-render", "--out", str(out), *COARSE]) == 2
    assert str(out) in capsys.readouterr().err


def test_a_temporary_exists_only_once_written(tmp_path):
    """``atomic_path`` names its temporary without making it: entered and never left (Ctrl-C between entering it
    and an ExitStack registering its exit, as the fe and rom stages enter theirs) it leaves no file. It used to
    make the file on entering (``mkstemp``): CI found a ``.partial-BRB-*.npz`` left by rom after Ctrl-C."""
    entered = atomic_path(tmp_path / "BRB.npz")
    temporary = entered.__enter__()  # its exit never registered
    assert temporary.parent == tmp_path and temporary.name.startswith(".partial-BRB-") and temporary.suffix == ".npz"
    assert list(tmp_path.iterdir()) == []


def test_a_temporary_onto_a_folder_is_refused_naming_it(tmp_path):
    """``atomic_path`` onto a folder is refused before anything is written, naming the folder (the rename used to
    fail after the work, naming the temporary)."""
    (tmp_path / "report.md").mkdir()
    with pytest.raises(OutputFolderError, match=re.escape(f"{tmp_path / 'report.md'}: a folder")):
        with atomic_path(tmp_path / "report.md") as temporary:
            temporary.write_text("never")
    assert [path.name for path in tmp_path.iterdir()] == ["report.md"]


def test_a_full_disk_names_the_file_being_written(tmp_path):
    """A writer that fails for a full disk without naming a file (pyarrow, numpy) is said with the destination's
    path and the same errno, and its temporary is removed."""
    with pytest.raises(OSError, match=re.escape(f"{tmp_path / 'chunk.parquet'}: [Errno 28]")) as error:
        with atomic_path(tmp_path / "chunk.parquet") as temporary:
            temporary.write_bytes(b"PAR1")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert error.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []
