"""The reduction stage's files: whole-joint patches and the Hurty/Craig-Bampton superelement per beam.

Reads ``<beams>/<beam>.msh`` (+ ``.json``, geometry stage) and ``<fe>/<beam>.npz`` (+ ``.json``, FE stage) and
writes into ``<out>``: ``<beam>.npz`` (``np.load(..., allow_pickle=False)``; ``reduction.superelement.
load_superelement`` reads it), the same arrays as MATLAB ``<beam>.mat``, ``<beam>_first_bending.png`` (the first
flexible mode with the joint stuck, expanded to the mesh) and the sidecar ``<beam>.json`` last (layout
``pipeline.cache``; files ``npz``, ``mat``, ``png``; also mass properties and frequencies). Its inputs, hashed into
the cache key, are the mesh and FE results' hashes and the ``ReductionParameters`` (number of fixed-interface modes,
sensor layout): a rerun with unchanged inputs does nothing. Parameters: a ``[reduction]`` table in a ``--config``
TOML file, ``--set reduction.fixed_interface_modes=30``, ``--modes``.

Reduced coordinates q (n = 86): lower virtual nodes 1-5, upper virtual nodes 1-5 (u_x, u_y, u_z m; r_x, r_y, r_z
rad, about the patch centroids) and 26 fixed-interface modal coordinates (``dof_labels``). Arrays:
- mass (n, n) kg; stiffness (n, n) N/m: K of the two halves (12 zero-energy modes); stiffness_prestressed (n, n)
  N/m: K_A = K + K_sigma of the clamped halves (indefinite when free); bolt_stress_stiffness (n, n) N/m: the
  preloaded shanks' string term, part of the joint; K_A + bolt_stress_stiffness + joint is the reduced full
  prestressed model (``reduction.whole_joint``);
- patch_motion (30, n): relative virtual-node motion upper minus lower of patch p, rows 6 p .. 6 p + 5;
  patch_areas (5,) m^2; patch_groups (5,) 0-based symmetry groups (0, 1, 2, 1, 0); patch_pairs (5, 2) indices of
  the lower and upper virtual node of each pair (0-based; 1-based in the .mat); virtual_node_coordinates (10, 3) m;
  patch_second_moments (5, 2, 2) m^4, each lower patch's J = int [[y^2, -x y], [-x y, x^2]] dA about its virtual
  node (the joint's normal springs act on the patch rotations through it, ``Superelement.joint_motion``);
- sensors (10, n): u_z (m) at the accelerometers; sensor_points (10, 3) m (``reduction.sensors``); preload (n,)
  N, generalised force of the bolt pretension; name;
- interface_points (n_pairs, 3) m and interface_lower_recovery, interface_upper_recovery (3 n_pairs, n): the
  displacement of every interface node pair (rows 3 i + k, component k), so patch slip can be drawn;
- vertex_recovery (3 n_vertices, n) and tetrahedra (n_tetrahedra, 4) (0-based; 1-based in the .mat): the
  displacement of every mesh vertex (``<beams>/<beam>.msh`` node order), for renders;
- dof_labels (n,) str; fixed_interface_frequencies (26,) Hz.
The .mat holds the same arrays, with ``M`` = mass, ``K`` = stiffness, ``K_prestressed``, ``K_bolt_stress``.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem.bolts import Bolt
from fem.elasticity import solid_mesh
from fem.fe_files import FeInputError, beam_inputs, read_csr
from fem.modes import interface_quadratic_pairs, node_dofs
from geometry.beam_mesh import interface_partners, read_beam_mesh
from pipeline.cache import is_current, sidecar_record, stage_versions, upstream_file
from pipeline.files import atomic_paths, write_json, write_mat

from .craig_bampton import N_FIXED_INTERFACE_MODES, reduced_matrix, rigid_body_properties, virtual_dof_labels
from .render import render_mode
from .sensors import BODY_FRACTIONS, SENSOR_DIRECTION, accelerometer_points, point_recovery
from .superelement import Superelement, rigid_reduced_coordinates, stuck_joint_modes, superelement_arrays
from .whole_joint import bolt_string_stiffness, preload_vector, reduce_beam, whole_joint_superelement

# 2: stiffness is K; K_A and the bolt string term beside it. 3: sidecar layout of pipeline.cache.
# 4: patch_second_moments.
FORMAT_VERSION = 4
VERSIONS = stage_versions(FORMAT_VERSION, "numpy", "scipy", "scikit-fem")  # the sidecar's versions
ONE_BASED = ("patch_pairs", "tetrahedra")  # index arrays shifted by one in the .mat
FE_ARRAYS = ("coordinates", *(f"{matrix}_{part}" for matrix in ("stiffness", "mass", "stress_stiffness")
                              for part in ("data", "indices", "indptr", "shape")))  # of the FE .npz, read here


@dataclass(frozen=True)
class ReductionParameters:
    """The reduction stage's own parameters (``[reduction]`` table).

    fixed_interface_modes: fixed-interface modes kept in the superelement, at least 1;
    sensor_body_fractions: accelerometer positions along each body from the lap end, fractions of the body
    length inside (0, 1) (``reduction.sensors``).
    """

    fixed_interface_modes: int = N_FIXED_INTERFACE_MODES
    sensor_body_fractions: tuple[float, ...] = BODY_FRACTIONS

    def __post_init__(self) -> None:
        if self.fixed_interface_modes < 1:
            raise FeInputError(f"parameter 'fixed_interface_modes' = {self.fixed_interface_modes}: expected at "
                               f"least 1 fixed-interface mode")
        if not self.sensor_body_fractions or not all(0.0 < f < 1.0 for f in self.sensor_body_fractions):
            raise FeInputError(f"parameter 'sensor_body_fractions' = {self.sensor_body_fractions}: expected "
                               f"fractions of the body length inside (0, 1)")


def fe_inputs(fe_folder: Path, name: str, mesh_sha: str) -> tuple[Path, dict]:
    """The FE result of one beam and its sidecar record; FeInputError when missing, stale, for another mesh, or
    not an .npz holding every array in FE_ARRAYS (a damaged or foreign file whose hash the sidecar records
    anyway: a BadZipFile, a pickle refused, or a KeyError deep in the reduction otherwise)."""
    sidecar = Path(fe_folder) / f"{name}.json"
    result, record = upstream_file(sidecar, "npz", "fe")
    if record.get("inputs", {}).get("mesh_sha256") != mesh_sha:
        raise FeInputError(f"{sidecar}: FE result of another mesh than the current one; rerun make fe")
    try:
        with np.load(result, allow_pickle=False) as arrays:
            missing = sorted(set(FE_ARRAYS) - set(getattr(arrays, "files", ())))
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
        raise FeInputError(f"{result}: not a readable .npz of the FE stage ({error}); rerun make fe") from None
    if missing:
        raise FeInputError(f"{result}: array(s) {missing} missing from the FE stage's .npz; rerun make fe")
    return result, record


def rom_arrays(beam_mesh, beam, fe, bolt: Bolt, parameters: ReductionParameters = ReductionParameters()
               ) -> tuple[Superelement, dict[str, np.ndarray]]:
    """The superelement of one beam and every array of its .npz (module docstring).

    beam_mesh: ``geometry.beam_mesh.BeamMesh``; beam: its ``BeamParameters``; fe: the loaded FE stage .npz;
    bolt: the FE stage's ``Bolt``."""
    n_modes = parameters.fixed_interface_modes
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    mass = read_csr(fe, "mass")
    reduction = reduce_beam(mesh, beam_mesh, read_csr(fe, "stiffness"), mass, n_modes)
    basis = reduction.hcb.basis
    string = bolt_string_stiffness(mesh, beam_mesh, beam, bolt)
    prestressed = reduction.hcb.stiffness + reduced_matrix(read_csr(fe, "stress_stiffness") - string, basis)
    points = accelerometer_points(beam, parameters.sensor_body_fractions)
    sensors = point_recovery(mesh, points)[SENSOR_DIRECTION::3] @ basis
    superelement = whole_joint_superelement(reduction, reduction.hcb.stiffness, sensors,
                                            preload_vector(mesh, beam_mesh, beam, bolt, basis), beam.name)
    lower, upper = interface_quadratic_pairs(mesh, *interface_partners(beam_mesh))
    n_patches = len(reduction.patch_areas)
    return superelement, {**superelement_arrays(superelement),
            "stiffness_prestressed": prestressed,
            "bolt_stress_stiffness": reduced_matrix(string, basis),
            "patch_pairs": np.column_stack([np.arange(n_patches), n_patches + np.arange(n_patches)]),
            "virtual_node_coordinates": np.vstack([reduction.references, reduction.references]),
            "sensor_points": points,
            "interface_points": fe["coordinates"][lower],
            "interface_lower_recovery": basis[node_dofs(lower).ravel()],
            "interface_upper_recovery": basis[node_dofs(upper).ravel()],
            "vertex_recovery": basis[:3 * mesh.p.shape[1]],
            "tetrahedra": mesh.t.T.copy(),
            "dof_labels": np.array(virtual_dof_labels(n_patches, n_modes)),
            "fixed_interface_frequencies": reduction.hcb.fixed_interface_frequencies}


def matlab_arrays(arrays: dict[str, np.ndarray]) -> dict:
    """The .mat content: M, K, K_prestressed, K_bolt_stress, 1-based index arrays, labels as a cell array."""
    renamed = {"mass": "M", "stiffness": "K", "stiffness_prestressed": "K_prestressed",
               "bolt_stress_stiffness": "K_bolt_stress"}
    content = {renamed.get(key, key): value + 1 if key in ONE_BASED else value for key, value in arrays.items()}
    content["dof_labels"] = np.array(list(arrays["dof_labels"]), dtype=object)
    return content


def make_rom(name: str, beams_folder: Path, fe_folder: Path, folder: Path,
             parameters: ReductionParameters = ReductionParameters(), render: bool = True) -> Path:
    """Run the reduction stage for one beam unless its sidecar is current; returns the sidecar path."""
    mesh_path, beam, mesh_sha = beam_inputs(beams_folder, name)
    fe_path, fe_record = fe_inputs(fe_folder, name, mesh_sha)
    inputs = {"mesh_sha256": mesh_sha, "fe_input_hash": fe_record["input_hash"],
              "fe_sha256": fe_record["files"]["npz"]["sha256"],
              "n_modes": parameters.fixed_interface_modes,
              "sensor_body_fractions": list(parameters.sensor_body_fractions)}
    folder = Path(folder)
    sidecar = folder / f"{name}.json"
    files = {"npz": folder / f"{name}.npz", "mat": folder / f"{name}.mat"}
    if render:
        files["png"] = folder / f"{name}_first_bending.png"
    if is_current(sidecar, inputs, VERSIONS, files):
        return sidecar
    beam_mesh = read_beam_mesh(mesh_path, beam)
    with np.load(fe_path, allow_pickle=False) as fe:
        superelement, arrays = rom_arrays(beam_mesh, beam, fe, Bolt(**fe_record["inputs"]["bolt"]), parameters)
    frequencies, shapes = stuck_joint_modes(superelement, 4)
    with atomic_paths(files) as temporary:
        with open(temporary["npz"], "wb") as stream:
            np.savez(stream, **arrays)
        write_mat(temporary["mat"], matlab_arrays(arrays))
        if render:
            render_mode(beam_mesh, (arrays["vertex_recovery"] @ shapes[:, 0]).reshape(-1, 3), temporary["png"],
                        f"{name}: first flexible mode, joint stuck, {frequencies[0]:.1f} Hz (superelement)")
    rigid = rigid_reduced_coordinates(arrays["virtual_node_coordinates"][:superelement.n_patches],
                                      superelement.mass.shape[0])
    total_mass, centre, inertia = rigid_body_properties(rigid.T @ superelement.mass @ rigid)
    write_json(sidecar, sidecar_record(
        inputs, VERSIONS, files, mass_kg=total_mass, centre_of_mass_m=centre.tolist(),
        inertia_about_centre_kg_m2=inertia.tolist(), stuck_joint_frequencies_hz=frequencies.tolist(),
        fixed_interface_frequencies_hz=arrays["fixed_interface_frequencies"].tolist()))
    return sidecar
