"""``surrogacy fe``: the finite-element stage: preload with contact, stress stiffness and tied modes per beam.

Reads ``<beams>/<beam>.msh`` and its sidecar ``<beam>.json`` (geometry stage) and writes ``<out>/<beam>.npz``
(arrays only; ``np.load(..., allow_pickle=False)``) and ``<out>/<beam>.json`` (inputs, input hash, file hash),
the sidecar last. The input hash covers the mesh's SHA-256, the beam parameters, the material, the bolt and the
number of modes: a rerun with unchanged inputs finds a matching sidecar and does nothing.

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
displacement magnitude. Their SHA-256 are in the sidecar (renders) and part of the cache check.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from tqdm import tqdm

from geometry.beam_mesh import read_beam_mesh
from geometry.parameters import BEAMS, BeamParameters
from pipeline.files import atomic_path, sha256_file, sha256_json, write_json

from . import calibration, convergence
from .bolts import Bolt
from .elasticity import Material
from .prestress import PrestressedBeam, prestressed_beam
from .render import render_fe

FORMAT_VERSION = 1
N_MODES = 10
RENDERS = ("contact_pressure", "first_bending")  # <beam>_<kind>.png


class FeInputError(ValueError):
    """A missing or malformed input of the finite-element stage (file, field, expectation)."""


def beam_inputs(beams_folder: Path, name: str) -> tuple[Path, BeamParameters, str]:
    """The mesh file, beam parameters and mesh SHA-256 of one beam, from the geometry stage's sidecar.

    Raises FeInputError when the sidecar or mesh is missing, a field is absent, or the mesh's hash differs from
    the one recorded (a mesh changed since the geometry stage wrote it).
    """
    sidecar = Path(beams_folder) / f"{name}.json"
    if not sidecar.is_file():
        raise FeInputError(f"{sidecar}: missing; run the geometry stage first (make beams)")
    try:
        record = json.loads(sidecar.read_text())
        mesh_entry, beam_record = record["files"]["msh"], record["beam"]
        mesh_path, mesh_sha = sidecar.parent / mesh_entry["name"], mesh_entry["sha256"]
    except (json.JSONDecodeError, KeyError, TypeError) as error:
        raise FeInputError(f"{sidecar}: expected JSON with files.msh.name, files.msh.sha256 and beam ({error!r})"
                           ) from None
    if not mesh_path.is_file():
        raise FeInputError(f"{mesh_path}: missing mesh named in {sidecar}")
    if sha256_file(mesh_path) != mesh_sha:
        raise FeInputError(f"{mesh_path}: SHA-256 differs from files.msh.sha256 in {sidecar}; rerun make beams")
    try:
        beam = BeamParameters(**{k: tuple(v) if isinstance(v, list) else v for k, v in beam_record.items()})
    except (TypeError, ValueError) as error:
        raise FeInputError(f"{sidecar}: field beam is not a valid BeamParameters ({error})") from None
    return mesh_path, beam, mesh_sha


def input_record(mesh_sha: str, beam: BeamParameters, material: Material, bolt: Bolt, n_modes: int) -> dict:
    """Everything the FE result depends on, as recorded in the sidecar and hashed into the cache key."""
    return {"format_version": FORMAT_VERSION, "mesh_sha256": mesh_sha, "beam": dataclasses.asdict(beam),
            "material": dataclasses.asdict(material), "bolt": dataclasses.asdict(bolt), "n_modes": n_modes}


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


def _is_current(sidecar: Path, input_hash: str) -> bool:
    if not sidecar.is_file():
        return False
    record = json.loads(sidecar.read_text())
    files = [record.get("file", {}), *record.get("renders", {}).values()]
    return (record.get("input_hash") == input_hash and len(files) == 1 + len(RENDERS)
            and all((sidecar.parent / entry.get("name", "")).is_file()
                    and sha256_file(sidecar.parent / entry["name"]) == entry["sha256"] for entry in files))


def make_fe(name: str, beams_folder: Path, folder: Path, material: Material = Material(), bolt: Bolt = Bolt(),
            n_modes: int = N_MODES) -> Path:
    """Run the FE stage for one beam unless its sidecar is current; returns the sidecar path."""
    if n_modes < 7:
        raise FeInputError(f"n_modes = {n_modes}: expected at least 7 (six rigid-body modes and first bending)")
    mesh_path, beam, mesh_sha = beam_inputs(beams_folder, name)
    inputs = input_record(mesh_sha, beam, material, bolt, n_modes)
    input_hash = sha256_json(inputs)
    folder = Path(folder)
    sidecar, result = folder / f"{name}.json", folder / f"{name}.npz"
    if _is_current(sidecar, input_hash):
        return sidecar
    beam_mesh = read_beam_mesh(mesh_path)
    model = prestressed_beam(beam_mesh, beam, material, bolt, n_modes)
    renders = {kind: folder / f"{name}_{kind}.png" for kind in RENDERS}
    with contextlib.ExitStack() as stack:  # every file renamed into place only if all were written
        temporary = stack.enter_context(atomic_path(result))
        with open(temporary, "wb") as stream:
            np.savez(stream, **fe_arrays(model))
        result_sha = sha256_file(temporary)
        images = {kind: stack.enter_context(atomic_path(path)) for kind, path in renders.items()}
        pressure_range = render_fe(beam_mesh, model, name, images["contact_pressure"], images["first_bending"])
        image_shas = {kind: sha256_file(path) for kind, path in images.items()}
    write_json(sidecar, {"inputs": inputs, "input_hash": input_hash,
                         "file": {"name": result.name, "sha256": result_sha},
                         "renders": {kind: {"name": path.name, "sha256": image_shas[kind]}
                                     for kind, path in renders.items()},
                         "contact_pressure_range_pa": list(pressure_range),
                         "first_bending_hz": {"tied": float(model.frequencies[6]),
                                              "tied_prestressed": float(model.prestressed_frequencies[6])}})
    return sidecar


def run(arguments: argparse.Namespace) -> None:
    material = Material(arguments.youngs_modulus, arguments.poissons_ratio, arguments.density)
    for name in tqdm(arguments.beam, desc="FE models", unit="beam"):
        tqdm.write(f"{name}: {make_fe(name, arguments.beams, arguments.out, material, Bolt(), arguments.modes)}")


def register(subparsers) -> None:
    """Add the ``fe`` subcommand and the FE studies (``fe-convergence``, ``calibrate``)."""
    defaults = Material()
    command = subparsers.add_parser(
        "fe", help="preload with contact, stress stiffness and tied modes of each beam: build/fe/<beam>.npz",
        description=__doc__)
    command.add_argument("--beam", nargs="+", choices=sorted(BEAMS), default=list(BEAMS), help="beams to solve")
    command.add_argument("--beams", type=Path, default=Path("build/beams"), help="geometry stage output folder")
    command.add_argument("--out", type=Path, default=Path("build/fe"), help="output folder")
    command.add_argument("--modes", type=int, default=N_MODES, help="tied modes per solve, six rigid included")
    command.add_argument("--youngs-modulus", type=float, default=defaults.youngs_modulus, help="Pa")
    command.add_argument("--poissons-ratio", type=float, default=defaults.poissons_ratio)
    command.add_argument("--density", type=float, default=defaults.density, help="kg/m^3")
    command.set_defaults(run=run)
    convergence.register(subparsers)
    calibration.register(subparsers)
