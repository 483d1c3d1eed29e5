"""Reading back the records the stages wrote (JSON files, CSV tables): an absent file is None, a damaged one (cut
short, not one JSON object, a field missing or of another type) a ValueError naming it, never a traceback or half
a row."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path


def read_record(path: Path) -> dict | None:
    """The JSON object a stage wrote at ``path`` (None where the file is absent); a damaged file (cut short, not
    one JSON object) raises a ValueError naming it."""
    if not path.exists():
        return None
    try:
        value = json.loads(path.read_text(errors="replace"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: not one JSON object ({error}); rerun the stage that writes it") from error
    if not isinstance(value, dict):
        raise ValueError(f"{path}: not one JSON object; rerun the stage that writes it")
    return value


@contextlib.contextmanager
def read_as(path: Path, what: str):
    """Reading the record ``path`` (a ``what``) in the block: a field missing or of another type, or a table that
    does not parse, raises a ValueError naming the file and the field (never a traceback, never half a row)."""
    try:
        yield
    except KeyError as error:
        raise ValueError(f"{path}: not a {what}: field {error} missing (rerun the stage that writes it)") from error
    except (IndexError, TypeError, ValueError) as error:
        raise ValueError(f"{path}: not a {what}: a field not as written ({error}; rerun the stage that writes "
                         "it)") from error
