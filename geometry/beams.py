"""The geometry stage: mesh a beam and write ``<beam>.msh``, ``<beam>.vtu``, ``<beam>.png`` and ``<beam>.json``.

The JSON sidecar (layout ``pipeline.cache``: inputs ``beam`` and ``mesh``, versions of the format, gmsh and
meshio, files ``msh``, ``vtu`` and ``png``) also records the node count, the physical groups with their element
counts, and the analytic, exact CAD and meshed volumes and patch areas. It is written last: a current sidecar
marks a complete result, and ``make_beam`` then does nothing. All files are written atomically.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import meshio
import numpy as np

from pipeline.cache import is_current, sidecar_record, stage_versions
from pipeline.files import atomic_paths, write_json

from . import properties
from .beam_mesh import read_beam_mesh
from .brake_reuss import build_beam_mesh, cad_measures, gmsh_session, write_msh
from .parameters import BeamParameters, MeshParameters, check_mesh_size
from .render import render_patches

FORMAT_VERSION = 2  # 2: sidecar layout of pipeline.cache
VERSIONS = stage_versions(FORMAT_VERSION, "gmsh", "meshio")  # the sidecar's versions


def input_record(beam: BeamParameters, sizes: MeshParameters) -> dict:
    """Everything the mesh depends on, as recorded in the sidecar and hashed into the cache key."""
    return {"beam": dataclasses.asdict(beam), "mesh": dataclasses.asdict(sizes)}


def _write_vtu(mesh, path: Path) -> None:
    """Tetrahedra (cell data ``half``: 1 lower, 2 upper) and named faces (``patch``: patch number, 0 elsewhere)."""
    tetra = [mesh.volumes["lower_half"], mesh.volumes["upper_half"]]
    patch_names = sorted(name for name in mesh.faces if "_patch_" in name)
    triangles = [mesh.faces[name] for name in patch_names]
    corner_count = tetra[0].shape[1]
    kind = {4: ("tetra", "triangle"), 10: ("tetra10", "triangle6")}[corner_count]
    cells = [(kind[0], np.vstack(tetra)), (kind[1], np.vstack(triangles))]
    half = np.concatenate([np.full(len(t), i + 1) for i, t in enumerate(tetra)])
    patch = np.concatenate([np.full(len(t), int(n.rsplit("_", 1)[1])) for n, t in zip(patch_names, triangles)])
    cell_data = {"half": [half, np.zeros(len(patch), dtype=int)], "patch": [np.zeros(len(half), dtype=int), patch]}
    meshio.write(path, meshio.Mesh(mesh.points, cells, cell_data=cell_data), file_format="vtu")


def _measured(beam: BeamParameters, mesh) -> dict:
    """Volumes and patch areas measured on the mesh, m^3 and m^2."""
    volumes = {name: float(properties.tetrahedron_volumes(mesh.points, tets).sum())
               for name, tets in mesh.volumes.items()}
    areas = {name: float(properties.triangle_areas(mesh.points, tris).sum())
             for name, tris in mesh.faces.items() if "_patch_" in name}
    return {"volume_m3": volumes, "patch_area_m2": areas,
            "mass_kg": beam.density * sum(volumes.values())}


def make_beam(beam: BeamParameters, sizes: MeshParameters, folder: Path, render: bool = True) -> Path:
    """Mesh one beam into ``folder`` unless a current result is already there. Returns the sidecar's path."""
    check_mesh_size(beam, sizes)
    folder = Path(folder)
    inputs = input_record(beam, sizes)
    sidecar = folder / f"{beam.name}.json"
    files = {"msh": folder / f"{beam.name}.msh", "vtu": folder / f"{beam.name}.vtu"}
    if render:
        files["png"] = folder / f"{beam.name}.png"
    if is_current(sidecar, inputs, VERSIONS, files):
        return sidecar
    with atomic_paths(files) as temporary:
        with gmsh_session():
            groups = build_beam_mesh(beam, sizes)
            cad = cad_measures(groups)
            write_msh(str(temporary["msh"]))
        mesh = read_beam_mesh(temporary["msh"], beam)
        _write_vtu(mesh, temporary["vtu"])
        if render:
            render_patches(mesh, temporary["png"], f"{beam.name}: interface patches 1-5 (upper half lifted)")
    write_json(sidecar, sidecar_record(
        inputs, VERSIONS, files,
        nodes=len(mesh.points),
        tetrahedra={name: len(tets) for name, tets in mesh.volumes.items()},
        physical_groups={name: {"dimension": groups[name][0], "entities": groups[name][1],
                                "elements": len(mesh.volumes.get(name, mesh.faces.get(name, [])))}
                         for name in groups},
        analytic={"half_volume_m3": properties.half_volume(beam), "mass_kg": properties.beam_mass(beam),
                  "patch_area_m2": properties.patch_areas(beam).tolist()},
        cad={"volume_m3": {n: v for n, v in cad.items() if groups[n][0] == 3},
             "patch_area_m2": {n: v for n, v in cad.items() if "_patch_" in n}},
        measured=_measured(beam, mesh)))
    return sidecar
