"""Benchmark of the geometry stage: time and peak memory to mesh each beam at the default sizes.

Run: ``python -m benchmarks.geometry`` (part of ``make bench``).
"""

from __future__ import annotations

import tempfile

from benchmarks.peak import measure


def mesh_beam(name: str) -> dict:
    """Mesh one beam (no render) into a scratch folder; returns node and element counts."""
    from geometry.beam_mesh import read_beam_mesh
    from geometry.beams import make_beam
    from geometry.parameters import BEAMS, MeshParameters

    with tempfile.TemporaryDirectory() as folder:
        sidecar = make_beam(BEAMS[name], MeshParameters(), folder, render=False)
        mesh = read_beam_mesh(sidecar.with_suffix(".msh"))
        return {"nodes": len(mesh.points), "tetrahedra": len(mesh.tetrahedra)}


def main() -> None:
    print("geometry: meshing at the default sizes (gmsh, one thread)")
    print(f"{'beam':6} {'nodes':>8} {'tetrahedra':>11} {'time s':>8} {'peak MiB':>9}")
    for name in ("BRB", "LBRB", "SBRB"):
        seconds, peak, counts = measure(mesh_beam, name)
        print(f"{name:6} {counts['nodes']:8d} {counts['tetrahedra']:11d} {seconds:8.2f} {peak:9.0f}")


if __name__ == "__main__":
    main()
