"""Benchmark of the geometry stage: time and peak memory to mesh each beam at the default sizes.

Run: ``python -m benchmarks.geometry`` (part of ``make bench``).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator

from benchmarks.peak import measure
from benchmarks.table import row, show
from geometry.parameters import BEAM_NAMES



def mesh_beam(name: str) -> dict:
    """Mesh one beam (no render) into a scratch folder; returns node and element counts."""
    from geometry.beam_mesh import read_beam_mesh
    from geometry.beams import make_beam
    from geometry.parameters import BEAMS, MeshParameters

    with tempfile.TemporaryDirectory() as folder:
        sidecar = make_beam(BEAMS[name], MeshParameters(), folder, render=False)
        mesh = read_beam_mesh(sidecar.with_suffix(".msh"))
        return {"nodes": len(mesh.points), "tetrahedra": len(mesh.tetrahedra)}


def rows() -> Iterator[dict]:
    """A row per beam: wall time (s) and peak memory (MiB) of meshing it in a fresh process (gmsh, one thread)."""
    for name in BEAM_NAMES:
        seconds, peak, counts = measure(mesh_beam, name)
        yield row("geometry", f"{name} mesh", seconds, peak,
                  note=f"default sizes, {counts['nodes']:,} nodes, {counts['tetrahedra']:,} tetrahedra")


def main() -> None:
    show(rows())


if __name__ == "__main__":
    main()
