"""Where the tests find the repository and the shared data beside it (``../shared``: the real measurements and
the paper's tables; tests that need them skip with the path in the reason where it is absent)."""

import gzip
from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[1]
SHARED = REPOSITORY.parent / "shared"
CHALLENGE = SHARED / "data" / "ringdown-challenge"  # virtual ring-downs from another generator, with their key
ASB_MODELS = SHARED / "data" / "asb-reduced-models"  # the ASB's reduced models, MAT_NULLRED_<configuration>.mat
ASB_BACKBONES = SHARED / "data" / "asb-backbones"  # the ASB's measured backbones, ASB_<configuration>_20Nm_BB.mat
REFERENCE = SHARED / "reference"  # the paper's tables and the BRB deck's dimensions, as transcribed files


def challenge_ringdown(name: str, folder: Path) -> Path:
    """The challenge set's ring-down ``name`` (e.g. "P1") unpacked into ``folder`` as the CSV a user gives
    ``surrogacy freevib``; the test skips with the path where the set is absent."""
    packed = CHALLENGE / f"{name}.csv.gz"
    if not packed.is_file():
        pytest.skip(f"the ring-down challenge set is absent ({packed})")
    path = Path(folder) / f"{name}.csv"
    path.write_bytes(gzip.decompress(packed.read_bytes()))
    return path
