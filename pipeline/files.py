"""Atomic result files and content hashes, shared by every stage.

A stage writes each output to a temporary file in the destination folder and renames it into place, so a
reader (or an interrupted run) never sees a half-written file; the JSON sidecar is renamed last and marks the
set as complete. Temporary files are named ``.partial-<stem>-<random><suffix>``: a run killed outright (SIGKILL)
leaves them behind, and the next run of the stage sweeps them (``sweep_partial_files``) while it holds the
folder's lock (``folder_lock``), so that it never removes a file another run is still writing.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import secrets
from pathlib import Path

import numpy as np
import scipy.io


PARTIAL = ".partial-"  # prefix of the temporary files of atomic_path
LOCK = ".lock"
MAT_DESCRIPTION = b"MATLAB 5.0 MAT-file, written by surrogacy"  # the .mat header's text, fixed (write_mat)


class FolderBusyError(ValueError):
    """Another run holds the lock of the folder this run would write."""


class OutputFolderError(ValueError):
    """An output folder that cannot be one: a file, a path below a file, or a folder this user may not write."""


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def sha256_json(value) -> str:
    """Hex SHA-256 of a JSON-serialisable value in canonical form (sorted keys): a cache key of inputs."""
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()


@contextlib.contextmanager
def atomic_path(destination: Path):
    """Yield a temporary path beside ``destination`` (``.partial-<stem>-<random><suffix>``, not yet created: the
    caller's writing creates it); rename it onto ``destination`` only on success.

    On any exception (Ctrl-C and SIGTERM included) the temporary file is removed and ``destination`` is left as
    it was. Nothing is created before the caller's ``with`` block (or ExitStack) has registered the exit: an
    interruption between the two leaves no file. A ``destination`` that is a folder is refused
    (``check_output_file``); an OSError that names no file (a full disk, as a library's writer reports it) is
    raised again naming ``destination``.
    """
    destination = Path(destination)
    check_output_file(destination)
    destination.parent.mkdir(parents=True, exist_ok=True)
    temporary = destination.with_name(f"{PARTIAL}{destination.stem}-{secrets.token_hex(6)}{destination.suffix}")
    try:
        yield temporary
        os.replace(temporary, destination)
    except OSError as error:
        if error.filename is not None:
            raise
        raise naming(error, destination) from error
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temporary)


def naming(error: OSError, path: Path) -> OSError:
    """An OSError saying ``error`` with ``path`` in front, its errno kept: the file a write failed on."""
    named = OSError(f"{path}: {error}")
    named.errno = error.errno
    return named


def strict_json(value):
    """``value`` as strict JSON can hold it (RFC 8259 has no NaN or Infinity), recursively through dicts, lists and
    tuples: every non-finite float (NaN, +-inf; Python's or numpy's) as None, numpy scalars and arrays as Python
    numbers and lists."""
    if isinstance(value, dict):
        return {key: strict_json(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(item) for item in value]
    if isinstance(value, (np.ndarray, np.generic)):
        return strict_json(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value, **options) -> str:
    """``value`` as strict JSON text (``strict_json``: a number that is not finite written as null); ``options``
    go to json.dumps."""
    return json.dumps(strict_json(value), allow_nan=False, **options)


def json_float(value) -> float:
    """A number read back from a JSON file of this project: null (a NaN or infinity, ``strict_json``) as NaN."""
    return math.nan if value is None else float(value)


def write_json(destination: Path, value) -> None:
    """Write ``value`` as indented strict JSON (``json_text``: NaN and infinities as null), atomically."""
    with atomic_path(destination) as temporary:
        temporary.write_text(json_text(value, indent=2, sort_keys=True) + "\n")


@contextlib.contextmanager
def atomic_paths(files: dict[str, Path]):
    """Yield a temporary path (``atomic_path``) for every file of one result, kind -> path; all are renamed into
    place only if every one was written, none otherwise (a stage's files never disagree)."""
    with contextlib.ExitStack() as stack:
        yield {kind: stack.enter_context(atomic_path(path)) for kind, path in files.items()}


def write_mat(path: Path, content: dict) -> None:
    """Write ``content`` (name -> array) as a compressed MATLAB 5 file whose bytes depend on the content only.

    ``scipy.io.savemat`` stamps the 128-byte file header with the time of writing ("Created on: ..."), so the
    same inputs gave another .mat (and sidecar hash) on every run. Here the header is written first, with a fixed
    description (116 bytes, space-padded), no subsystem offset, version 0x0100 and the byte-order mark in the
    native order savemat writes the data in; savemat, handed the stream past its start, then adds only the
    variables.
    """
    header = MAT_DESCRIPTION.ljust(116, b" ") + bytes(8) + np.array([0x0100, 0x4D49], dtype=np.uint16).tobytes()
    with open(path, "wb") as stream:
        stream.write(header)
        scipy.io.savemat(stream, content, do_compression=True)


def sweep_partial_files(folder: Path) -> list[Path]:
    """Remove the temporary files an interrupted run left in ``folder`` and below (hold ``folder_lock``);
    returns them."""
    swept = sorted(Path(folder).rglob(f"{PARTIAL}*"))
    for path in swept:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
    return swept


@contextlib.contextmanager
def folder_lock(folder: Path):
    """Hold an exclusive lock on ``folder`` (a ``.lock`` file in it, flock) while writing there: a second run
    into the same folder is refused with FolderBusyError instead of duplicating the work or racing it. The lock
    dies with its process, so a killed run never leaves the folder locked."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / LOCK, "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusyError(f"{folder}: another run is writing here (it holds {folder / LOCK}); wait for it "
                                  "to finish or use another folder") from None
        try:
            yield folder
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def check_output_folder(folder: Path) -> None:
    """Refuse an output folder that cannot be one, before any work: ``folder`` or the nearest of its parents that
    exists (a folder still to be made) must be a folder this user may write into. A stage that writes only at the
    end of a long solve checks this at its door, so that ``--out`` naming a file or a read-only folder is said in
    one line at once instead of as a traceback after the solve. Raises OutputFolderError naming the path."""
    folder = Path(folder)
    existing = next(path for path in (folder, *folder.parents) if path.exists())
    if not existing.is_dir():
        where = "a file" if existing == folder else f"below the file {existing}"
        raise OutputFolderError(f"{folder}: {where}; expected an output folder (existing or new)")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputFolderError(f"{folder}: {existing} is not writable by this user; expected a writable output "
                                "folder")


def check_output_file(path: Path) -> None:
    """Refuse an output file's path that names a folder, before any work. Raises OutputFolderError naming it."""
    if Path(path).is_dir():
        raise OutputFolderError(f"{path}: a folder; expected the name of a file to write (a new or existing file)")


@contextlib.contextmanager
def stage_folder(folder: Path):
    """A stage's output folder while it writes there: checked (``check_output_folder``), locked
    (``folder_lock``) and swept of the temporaries an interrupted run left (``sweep_partial_files``)."""
    check_output_folder(folder)
    with folder_lock(folder):
        sweep_partial_files(folder)
        yield Path(folder)
