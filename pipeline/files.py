"""Atomic result files and content hashes, shared by every stage.

A stage writes each output to a temporary file in the destination folder and renames it into place, so a
reader (or an interrupted run) never sees a half-written file; the JSON sidecar is renamed last and marks the
set as complete.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from pathlib import Path


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
    """Yield a temporary path beside ``destination``; rename it onto ``destination`` only on success.

    On any exception the temporary file is removed and ``destination`` is left as it was.
    """
    destination = Path(destination)
    destination.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{destination.stem}-", suffix=destination.suffix,
                                         dir=destination.parent)
    os.close(handle)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)
    try:
        yield Path(temporary)
        os.replace(temporary, destination)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temporary)


def write_json(destination: Path, value) -> None:
    """Write ``value`` as indented JSON, atomically."""
    with atomic_path(destination) as temporary:
        temporary.write_text(json.dumps(value, indent=2, sort_keys=True) + "\n")
