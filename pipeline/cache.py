"""The sidecar of a stage's result and the one cache check that every stage (beams, fe, rom) makes with it.

A stage writes the outputs of one beam atomically (``pipeline.files``), then the sidecar ``<beam>.json`` last, so
a sidecar whose hashes match the files on disk marks a complete result. Sidecar layout, one JSON object:

- ``inputs``: everything the outputs depend on (parameters, upstream files' hashes), a JSON object;
- ``input_hash``: ``sha256_json(inputs)``, the cache key;
- ``versions``: ``{"format": the stage's file-format version, <package>: its version or null}`` for each
  package whose arithmetic the outputs depend on; outputs of another format or other package versions are stale;
- ``files``: ``{kind: {"name": file name in the sidecar's folder, "sha256": hex SHA-256 of its bytes}}``, every
  output file (kind: ``"msh"``, ``"npz"``, ``"png"``, ...);
- then the stage's own results (measured volumes, frequencies, ...) under keys of their own.

``is_current`` decides from a stage's own sidecar whether to recompute: a missing, unreadable, truncated or
malformed sidecar means "stale, recompute", never an error. ``upstream_file`` reads the sidecar of the stage
before: there a missing or malformed sidecar, or a file whose hash differs, is an input error.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path

from tqdm import tqdm

from .files import sha256_file, sha256_json

STAGES = {"beams": "geometry", "fe": "FE", "rom": "reduction"}  # make target (and subcommand) -> stage name


class StageInputError(ValueError):
    """A missing, malformed or stale input of a stage: an upstream result or a parameter out of range."""


def package_versions(*packages: str) -> dict[str, str | None]:
    """The installed version of each named distribution (e.g. ``"scikit-fem"``), None where not installed."""
    def version(package: str) -> str | None:
        try:
            return metadata.version(package)
        except metadata.PackageNotFoundError:
            return None
    return {package: version(package) for package in packages}


def stage_versions(format_version: int, *packages: str) -> dict:
    """A stage's sidecar versions: the format of its files and the packages that produce them; a sidecar with
    other versions is not current (``is_current``)."""
    return {"format": format_version, **package_versions(*packages)}


def read_sidecar(path: Path) -> dict | None:
    """The sidecar's JSON object, or None when it is missing, unreadable, truncated or not a JSON object."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return record if isinstance(record, dict) else None


def _intact(folder: Path, entry) -> bool:
    """Whether a ``files`` entry names a file in ``folder`` whose SHA-256 is the recorded one."""
    if not (isinstance(entry, dict) and isinstance(entry.get("name"), str) and isinstance(entry.get("sha256"), str)):
        return False
    path = folder / entry["name"]
    return path.is_file() and sha256_file(path) == entry["sha256"]


def is_current(sidecar: Path, inputs: dict, versions: dict, kinds: Iterable[str]) -> bool:
    """Whether the result recorded by ``sidecar`` is current, so that the stage need not recompute it.

    Current: the sidecar is a JSON object with ``input_hash == sha256_json(inputs)``, ``versions`` equal to
    ``versions``, and ``files`` listing every kind in ``kinds`` (others may be listed too), each file present with
    its recorded SHA-256. Anything else, a corrupt or truncated sidecar included, is stale; a sidecar that exists
    but cannot be read is said so on one line of stderr (the rerun recomputes instead of failing on it).
    """
    record = read_sidecar(sidecar)
    if record is None and Path(sidecar).exists():
        tqdm.write(f"{sidecar}: unreadable sidecar (truncated or not a JSON object): stale, recomputing",
                   file=sys.stderr)
    if record is None or record.get("input_hash") != sha256_json(inputs) or record.get("versions") != versions:
        return False
    files = record.get("files")
    return (isinstance(files, dict) and set(kinds) <= set(files)
            and all(_intact(Path(sidecar).parent, entry) for entry in files.values()))


def sidecar_record(inputs: dict, versions: dict, files: dict[str, Path], **results) -> dict:
    """The sidecar of a result whose output files are in place (layout in the module docstring).

    files: kind -> path of each output file, hashed here; results: the stage's own entries.
    """
    return {"inputs": inputs, "input_hash": sha256_json(inputs), "versions": versions,
            "files": {kind: {"name": path.name, "sha256": sha256_file(path)} for kind, path in files.items()},
            **results}


def upstream_file(sidecar: Path, kind: str, stage: str) -> tuple[Path, dict]:
    """The output file of ``kind`` recorded in the sidecar of an earlier stage, checked, and the sidecar record.

    stage: the earlier stage's make target (a key of ``STAGES``), named in the errors. Raises StageInputError when
    the sidecar is missing or malformed, or the file it names is missing or has another SHA-256 than recorded.
    """
    sidecar = Path(sidecar)
    rerun = f"run the {STAGES[stage]} stage first (make {stage})"
    if not sidecar.is_file():
        raise StageInputError(f"{sidecar}: missing; {rerun}")
    record = read_sidecar(sidecar)
    try:
        entry = record["files"][kind]
        path, sha = sidecar.parent / entry["name"], entry["sha256"]
    except (KeyError, TypeError) as error:
        raise StageInputError(f"{sidecar}: expected a JSON sidecar with files.{kind}.name and files.{kind}.sha256 "
                              f"({error!r}); {rerun}") from None
    if not path.is_file():
        raise StageInputError(f"{path}: missing file named in {sidecar}; {rerun}")
    if sha256_file(path) != sha:
        raise StageInputError(f"{path}: SHA-256 differs from files.{kind}.sha256 in {sidecar}; {rerun}")
    return path, record
