"""Benchmark of the reduction stage: time and peak memory of each beam's superelement, from the pipeline's own
geometry and FE results (``build/beams``, ``build/fe``: ``make fe``, default meshes).

Each beam is reduced in a fresh process into a scratch folder (``reduction.rom_files.make_rom`` without the
render: whole-joint patches, Hurty/Craig-Bampton basis, prestress and sensor rows, the .npz and .mat written).
Run: ``python -m benchmarks.reduction`` (part of ``make bench``).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from benchmarks.peak import measure
from benchmarks.table import row, show
from geometry.parameters import BEAM_NAMES

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

BEAMS_FOLDER, FE_FOLDER = Path("build/beams"), Path("build/fe")


def reduce_beam(name: str) -> str:
    """Reduce one beam into a scratch folder; returns its stuck-joint first flexible frequency and size."""
    from reduction.rom_files import make_rom

    with tempfile.TemporaryDirectory() as folder:
        record = json.loads(make_rom(name, BEAMS_FOLDER, FE_FOLDER, Path(folder), render=False).read_text())
    return (f"{len(record['fixed_interface_frequencies_hz'])} fixed-interface modes, stuck joint first flexible "
            f"{record['stuck_joint_frequencies_hz'][0]:.1f} Hz")


def rows(beams=BEAM_NAMES) -> Iterator[dict]:
    """A row per beam: wall time (s) and peak memory (MiB) of its reduction, or why it was skipped (no current
    FE result of the beam's mesh)."""
    from fem.fe_files import FeInputError, beam_inputs
    from reduction.rom_files import fe_inputs

    for name in beams:
        try:
            fe_inputs(FE_FOLDER, name, beam_inputs(BEAMS_FOLDER, name)[2])
        except FeInputError as error:
            yield row("reduction", f"{name} superelement", note=f"skipped (run make fe): {error}")
            continue
        seconds, peak, result = measure(reduce_beam, name)
        yield row("reduction", f"{name} superelement", seconds, peak, note=f"default mesh (make fe): {result}")


def main() -> None:
    show(rows())


if __name__ == "__main__":
    main()
