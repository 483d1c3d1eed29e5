"""Stages after an interruption and beside a concurrent run (issue 17, item 5): the temporaries a killed run
left are swept when the stage next runs, and a second run into a folder another run is writing is refused with
one line naming the folder (exit 2), touching nothing."""

import fcntl

from pipeline.cli import main as surrogacy

COARSE = ["--set", "mesh.size=0.0127", "--set", "mesh.lap_size=0.0064", "--set", "mesh.hole_size=0.0032"]


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
