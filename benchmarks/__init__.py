"""``make bench`` (``python -m benchmarks``): one table of time, memory and throughput per stage."""

import os
from pathlib import Path

MEASURED_DATA = Path(os.environ.get("ASB_DATA") or next(
    (folder for folder in (Path("../shared/data"), Path("data")) if folder.is_dir()), Path("data")))
"""The measured data the benchmarks read (asb-backbones/, asb-reduced-models/, ...): ``$ASB_DATA`` (the
Makefile's), else ``../shared/data`` where it is, else the project's ``data/`` (``make data``); rows whose files
are absent say so and are skipped."""
ASB_MODELS = MEASURED_DATA / "asb-reduced-models"
"""The ASB's reduced models (``MAT_NULLRED_<configuration>.mat``)."""
