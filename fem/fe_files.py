"""The finite-element stage's files: preload with contact, stress stiffness and tied modes per beam.

Reads ``<beams>/<beam>.msh`` and its sidecar ``<beam>.json`` (geometry stage) and writes ``<out>/<beam>.npz``
(arrays only; ``np.load(..., allow_pickle=False)``) and ``<out>/<beam>.json``, the sidecar (layout
``pipeline.cache``), last. Its inputs, hashed into the cache key, are the mesh's SHA-256, the beam parameters, the
material, the bolt and the number of modes: a rerun with unchanged inputs finds a current sidecar and does nothing.
Parameters: ``[material]`` (``fem.elasticity.Material``) and ``[bolt]`` (``fem.bolts.Bolt``) tables of a
``--config`` TOML file, ``--set material.density=7850``, and the options below.

Arrays in the .npz (n_nodes quadratic nodes, n_dof = 3 n_nodes, DOF 3 p + k of component k at node p):
coordinates (n_nodes, 3) m; stiffness_* and mass_*: K (solid, N/m) and M (solid and bolt masses, kg) as CSR
components data, indices, indptr, shape; bolts_* (shanks with axial stiffness, N/m) and stress_stiffness_*
(K_sigma of solid and shanks, N/m) likewise; lower_nodes, upper_nodes (n_pairs,) interface partners;
preload_displacement (n_dof,) m; contact_force (n_pairs,) N on the upper nodes (+z); contact_active (n_pairs,)
bool; frequencies, prestressed_frequencies (n_modes,) Hz and shapes, prestressed_shapes (n_dof, n_modes),
mass-normalised tied modes of (K + K_bolts, M) and (K + K_bolts + K_sigma, M) (``fem.prestress``).

Renders (``fem.render``, paper Figs. 7a and 8): ``<out>/<beam>_contact_pressure.png``, the lower interface
coloured by the preload's contact pressure (Pa, colour range recorded in the sidecar as
contact_pressure_range_pa), and ``<out>/<beam>_first_bending.png``, the prestressed first bending mode coloured by
displacement magnitude. They are files ``contact_pressure`` and ``first_bending`` of the sidecar.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from geometry.beam_mesh import read_beam_mesh
from geometry.parameters import BeamParameters
from pipeline.cache import StageInputError, is_current, sidecar_record, stage_versions, upstream_file
from pipeline.files import atomic_paths, check_output_folder, sha256_json, write_json

from .bolts import Bolt
from .elasticity import Material
from .prestress import PrestressedBeam, prestressed_beam
from .render import render_fe

FORMAT_VERSION = 2  # 2: sidecar layout of pipeline.cache
VERSIONS = stage_versions(FORMAT_VERSION, "numpy", "scipy", "scikit-fem", "scikit-sparse")
N_MODES = 10
RENDERS = ("contact_pressure", "first_bending")  # <beam>_<kind>.png
FeInputError = StageInputError  # what the FE and reduction stages raise for a missing or bad input


def beam_inputs(beams_folder: Path, name: str) -> tuple[Path, BeamParameters, str]:
    """The mesh file, beam parameters and mesh SHA-256 of one beam, from the geometry stage's sidecar.

    Raises FeInputError when the sidecar or mesh is missing, a field is absent, the mesh's hash differs from
    the one recorded (a mesh changed since the geometry stage wrote it), the sidecar describes another beam or
    its inputs no longer hash to its recorded input_hash (edited by hand): never trusted, always checked.
    """
    sidecar = Path(beams_folder) / f"{name}.json"
    mesh_path, record = upstream_file(sidecar, "msh", "beams")
    try:
        beam = BeamParameters(**{k: tuple(v) if isinstance(v, list) else v
                                 for k, v in record["inputs"]["beam"].items()})
    except (KeyError, AttributeError, TypeError, ValueError) as error:
        raise FeInputError(f"{sidecar}: field inputs.beam is not a valid BeamParameters ({error!r}); "
                           f"rerun make beams") from None
    if beam.name != name or mesh_path.stem != name:
        raise FeInputError(f"{sidecar}: describes beam {beam.name!r} meshed in {mesh_path.name}, not the {name} "
                           "asked for; rerun make beams")
    if record.get("input_hash") != sha256_json(record["inputs"]):
        raise FeInputError(f"{sidecar}: field inputs no longer matches its input_hash (edited after meshing); "
                           "rerun make beams")
    return mesh_path, beam, record["files"]["msh"]["sha256"]


def input_record(mesh_sha: str, beam: BeamParameters, material: Material, bolt: Bolt, n_modes: int) -> dict:
    """Everything the FE result depends on, as recorded in the sidecar and hashed into the cache key."""
    return {"mesh_sha256": mesh_sha, "beam": dataclasses.asdict(beam), "material": dataclasses.asdict(material),
            "bolt": dataclasses.asdict(bolt), "n_modes": n_modes}


def _csr_arrays(name: str, matrix: sp.csr_matrix) -> dict[str, np.ndarray]:
    return {f"{name}_data": matrix.data, f"{name}_indices": matrix.indices, f"{name}_indptr": matrix.indptr,
            f"{name}_shape": np.array(matrix.shape)}


def fe_arrays(model: PrestressedBeam) -> dict[str, np.ndarray]:
    """The .npz content of a ``PrestressedBeam`` (names in the module docstring)."""
    return {"coordinates": model.coordinates,
            **_csr_arrays("stiffness", model.stiffness), **_csr_arrays("mass", model.mass),
            **_csr_arrays("bolts", model.bolts), **_csr_arrays("stress_stiffness", model.stress_stiffness),
            "lower_nodes": model.lower_nodes, "upper_nodes": model.upper_nodes,
            "preload_displacement": model.contact.displacement, "contact_force": model.contact.normal_force,
            "contact_active": model.contact.active,
            "frequencies": model.frequencies, "shapes": model.shapes,
            "prestressed_frequencies": model.prestressed_frequencies,
            "prestressed_shapes": model.prestressed_shapes}


def read_csr(arrays, name: str) -> sp.csr_matrix:
    """A CSR matrix stored by ``fe_arrays`` under ``name`` in a loaded .npz."""
    return sp.csr_matrix((arrays[f"{name}_data"], arrays[f"{name}_indices"], arrays[f"{name}_indptr"]),
                         shape=tuple(arrays[f"{name}_shape"]))


def check_fe_inputs(names, beams_folder: Path, folder: Path, n_modes: int = N_MODES) -> None:
    """Refuse, before the output ``folder`` is touched, FE runs of the beams ``names`` that cannot run: fewer than 7
    modes (six rigid-body modes and first bending), a folder that cannot be written, a beam whose geometry is
    missing or changed since the geometry stage (``beam_inputs``). Raises FeInputError naming the option as typed
    or the file, OutputFolderError for the folder."""
    if n_modes < 7:
        raise FeInputError(f"option --modes = {n_modes}: expected at least 7 (six rigid-body modes and first "
                           "bending)")
    check_output_folder(folder)
    for name in names:
        beam_inputs(beams_folder, name)


def make_fe(name: str, beams_folder: Path, folder: Path, material: Material = Material(), bolt: Bolt = Bolt(),
            n_modes: int = N_MODES) -> Path:
    """Run the FE stage for one beam unless its sidecar is current; returns the sidecar path."""
    if n_modes < 7:
        raise FeInputError(f"n_modes = {n_modes}: expected at least 7 (six rigid-body modes and first bending)")
    mesh_path, beam, mesh_sha = beam_inputs(beams_folder, name)
    inputs = input_record(mesh_sha, beam, material, bolt, n_modes)
    folder = Path(folder)
    sidecar = folder / f"{name}.json"
    files = {"npz": folder / f"{name}.npz", **{kind: folder / f"{name}_{kind}.png" for kind in RENDERS}}
    if is_current(sidecar, inputs, VERSIONS, files):
        return sidecar
    beam_mesh = read_beam_mesh(mesh_path, beam)
    model = prestressed_beam(beam_mesh, beam, material, bolt, n_modes)
    with atomic_paths(files) as temporary:
        with open(temporary["npz"], "wb") as stream:
            np.savez(stream, **fe_arrays(model))
        pressure_range = render_fe(beam_mesh, model, name, temporary["contact_pressure"], temporary["first_bending"])
    write_json(sidecar, sidecar_record(
        inputs, VERSIONS, files, contact_pressure_range_pa=list(pressure_range),
        first_bending_hz={"tied": float(model.frequencies[6]),
                          "tied_prestressed": float(model.prestressed_frequencies[6])}))
    return sidecar
