"""The registry of measured-data files: every format a measurement may come in, chosen by suffix and content.

A measured file is either a ring-down (hits of a free decay, :class:`~experiment.ringdown.RingDown`) or a backbone
of one mode (:class:`~experiment.backbone.ModeBackbone`). Each format of :data:`MEASURED_FORMATS` names its kind,
the suffixes it comes with, how its content is recognised where two formats share a suffix, and its reader; the
first format whose suffix and content match a file reads it. A file no format matches, or one of the wrong kind
for the step, raises one :class:`MeasuredFileError` that names the file and lists the formats.

Provenance. Each format also says where its file states whether the data are measured or virtual (simulated):
a ring-down CSV in a comment line before its header (``# provenance: measured`` or ``virtual``, or a comment
that calls the data virtual or simulated), a ring-down .mat in a top-level string variable ``provenance``, a
backbone in its own record; a file that does not say is "unknown" (UFF 58 has no place for it).

Layouts: ring-down files in :mod:`experiment.ringdown_files`, backbone files in :mod:`experiment.backbone_files`
(docs/formats.md has both).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import scipy.io

from experiment.backbone import PROVENANCES, ModeBackbone
from experiment.backbone_files import BACKBONE_TITLE, read_asb_backbone, read_backbone
from experiment.ringdown import RingDown
from experiment.ringdown_files import read_csv, read_mat, read_uff58

RING_DOWN = "ring-down"
BACKBONE = "backbone"


class MeasuredFileError(ValueError):
    """A file that is not a measurement in any known format, or not of the kind the step reads: names the file,
    the field and the problem."""

    def __init__(self, path: Path, field: str, problem: str):
        super().__init__(f"{path}: field '{field}': {problem}")


def starts_with_backbone_title(path: Path) -> bool:
    """A backbone CSV opens with its title comment (:data:`~experiment.backbone_files.BACKBONE_TITLE`)."""
    with open(path, encoding="utf-8-sig", errors="replace") as stream:
        return stream.readline().strip() == f"# {BACKBONE_TITLE}"


def holds_asb_backbone_vectors(path: Path) -> bool:
    """An ASB backbone .mat holds the vectors Q, W and Z (read from the file's index, without loading it); a file
    MATLAB's reader cannot index is left to the ring-down reader, which names the problem."""
    try:
        return {"Q", "W", "Z"} <= {name for name, _, _ in scipy.io.whosmat(path)}
    except (ValueError, OSError, scipy.io.matlab.MatReadError):
        return False


def checked_provenance(path: Path, stated: str) -> str:
    """A provenance a file states, which must be one of PROVENANCES; raises MeasuredFileError otherwise."""
    if stated not in PROVENANCES:
        raise MeasuredFileError(path, "provenance", f"'{stated}'; expected one of {PROVENANCES}")
    return stated


def csv_provenance(path: Path) -> str:
    """The provenance a CSV states in its comment lines before the header (module docstring)."""
    comments = []
    with open(path, encoding="utf-8-sig", errors="replace") as stream:
        for line in stream:
            if line.strip() and not line.lstrip().startswith("#"):
                break  # the header row: the comments that state the provenance come before it
            comments.append(line.strip().lstrip("#").strip())
    for comment in comments:
        key, _, value = comment.partition(":")
        if key.strip().lower() == "provenance":
            return checked_provenance(path, value.strip())
    words = " ".join(comments).lower()
    return "virtual" if "virtual" in words or "simulated" in words else "measured" if "measured" in words else "unknown"


def mat_provenance(path: Path) -> str:
    """The provenance a .mat states in a top-level string variable ``provenance`` (module docstring)."""
    try:
        stated = scipy.io.loadmat(path, variable_names=["provenance"]).get("provenance")
    except (ValueError, OSError, scipy.io.matlab.MatReadError):
        return "unknown"  # the reader names what is wrong with the file
    return "unknown" if stated is None else checked_provenance(path, str(np.ravel(stated)[0]).strip())


@dataclass(frozen=True)
class MeasuredFormat:
    """One format of measured file: its name, kind (:data:`RING_DOWN` or :data:`BACKBONE`), suffixes (lower case),
    the content test that tells it from another format with the same suffix, the reader (path -> list of
    RingDown, or ModeBackbone) and where the file states its provenance (path -> one of PROVENANCES)."""

    name: str
    kind: str
    suffixes: tuple[str, ...]
    recognises: Callable[[Path], bool]
    read: Callable[[Path], list[RingDown] | ModeBackbone]
    provenance: Callable[[Path], str]

    @property
    def description(self) -> str:
        return f"{self.name} ({', '.join(self.suffixes)})"


MEASURED_FORMATS = (
    MeasuredFormat("backbone CSV", BACKBONE, (".csv",), starts_with_backbone_title, read_backbone,
                   lambda path: read_backbone(path).provenance),
    MeasuredFormat("ring-down CSV", RING_DOWN, (".csv",), lambda path: True, read_csv, csv_provenance),
    MeasuredFormat("ASB backbone .mat (Q, W, Z)", BACKBONE, (".mat",), holds_asb_backbone_vectors, read_asb_backbone,
                   lambda path: read_asb_backbone(path).provenance),
    MeasuredFormat("ring-down .mat", RING_DOWN, (".mat",), lambda path: True, read_mat, mat_provenance),
    MeasuredFormat("ring-down UFF 58", RING_DOWN, (".uff", ".unv"), lambda path: True, read_uff58,
                   lambda path: "unknown"),
)
"""Every format a measurement is read from, in the order they are tried."""


def known_formats(kind: str | None = None) -> str:
    """The formats (of ``kind``, or all) as one line for an error message."""
    return "; ".join(entry.description for entry in MEASURED_FORMATS if kind in (None, entry.kind))


def measured_format(path: Path, kind: str | None = None) -> MeasuredFormat:
    """The format of the measured file ``path``: the first of :data:`MEASURED_FORMATS` whose suffix and content
    match. Raises MeasuredFileError for a missing file, a folder, an empty file (naming the formats of ``kind``,
    or all), or a file no format matches."""
    path = Path(path)
    if path.is_dir():
        raise MeasuredFileError(path, "file", f"a folder; expected a measured file: {known_formats()}")
    if not path.is_file():
        raise MeasuredFileError(path, "file", "does not exist")
    if path.stat().st_size == 0:
        raise MeasuredFileError(path, "file", f"empty (0 bytes); expected a {kind or 'measured file'}: "
                                              f"{known_formats(kind)}")
    for entry in MEASURED_FORMATS:
        if path.suffix.lower() in entry.suffixes and entry.recognises(path):
            return entry
    raise MeasuredFileError(path, "file", f"unknown suffix '{path.suffix}'; known formats: {known_formats()}")


def read_of_kind(path: Path, kind: str, instead: str):
    """The content of the measured file ``path``, which must be of ``kind``; ``instead`` says what to do with a
    file of the other kind. Raises MeasuredFileError naming the file and its format otherwise."""
    entry = measured_format(path, kind)
    if entry.kind != kind:
        raise MeasuredFileError(path, "file",
                                f"format {entry.name}; expected a {kind}: {known_formats(kind)}. {instead}")
    return entry.read(Path(path))


def read_ringdown(path: Path) -> list[RingDown]:
    """Ring-down hits from a file in any ring-down format of the registry (one RingDown per hit)."""
    return read_of_kind(path, RING_DOWN, "A backbone is read by the study and the discrepancy loop as it is.")


def read_mode_backbone(path: Path) -> ModeBackbone:
    """One mode's backbone from a file in any backbone format of the registry."""
    return read_of_kind(path, BACKBONE, "Process a ring-down into a backbone CSV first: surrogacy freevib FILE "
                                        "--mode-hz F writes <stem>_mode_<F>Hz_backbone.csv.")


def stated_provenance(path: Path) -> str:
    """Whether the measured file ``path`` states its data measured or virtual, "unknown" where it does not say
    (module docstring)."""
    return measured_format(path).provenance(Path(path))
