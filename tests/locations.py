"""Where the tests find the repository and the shared data beside it (``../shared``: the real measurements and
the paper's tables; tests that need them skip with the path in the reason where it is absent)."""

from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
SHARED = REPOSITORY.parent / "shared"
