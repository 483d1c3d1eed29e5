"""Mesh-convergence study of the tied first out-of-plane bending frequency (docs/design.md sections 2 and 3).

The three element sizes of ``geometry.parameters.MeshParameters`` (far field, lap, holes) are scaled together by
a factor s (s < 1 refines); each mesh is solved for the first out-of-plane bending frequency of the beam with the
lap tied (``fem.modes``: the upper bound of the low-amplitude frequencies) on the dynamic model's mass, the solid
plus the bolt, nut and washer masses (``fem.bolts.bolts_mass``; the bolts' stiffness is left out, it cannot act
across a tied lap beyond what the tie already does). Quadratic tetrahedra converge from above: the discrete
model is stiffer than the continuum, so the frequency decreases with refinement.

The default mesh is the coarsest whose frequency changes by less than a tolerance (0.5 %) to the next finer
mesh of the sequence and to every finer one (``converged_index``).
"""

from __future__ import annotations

import csv
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from skfem import MeshTet
from tqdm import tqdm

from geometry.beam_mesh import BeamMesh, interface_partners, read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BeamParameters, GeometryError, MeshParameters, check_mesh_size
from pipeline.files import atomic_path, check_output_folder, write_json

from .bolts import Bolt, bolts_mass, washer_couplings
from .elasticity import Material, mass_matrix, solid_mesh, stiffness_matrix
from .modes import interface_quadratic_pairs, tie_transformation, tied_modes

FACTORS = (2.0, 1.6, 1.25, 1.0, 0.8, 0.64)  # each step about 1.6 to 2 times the DOF
TOLERANCE = 0.005
N_MODES = 10
COLUMNS = ("factor", "size_m", "lap_size_m", "hole_size_m", "dof", "first_bending_hz", "change_to_finer",
           "seconds")


def scaled_sizes(sizes: MeshParameters, factor: float) -> MeshParameters:
    """``sizes`` with the far-field, lap and hole element sizes all multiplied by ``factor`` (same order)."""
    return dataclasses.replace(sizes, size=sizes.size * factor, lap_size=sizes.lap_size * factor,
                               hole_size=sizes.hole_size * factor)


def check_mesh_factor(option: str, factor: float, beams, sizes: MeshParameters) -> MeshParameters:
    """``sizes`` scaled by ``factor`` (a command-line ``option``), refused naming the option where the factor is
    not a positive finite scale or the scaled sizes would not fit in memory on one of ``beams``
    (``geometry.parameters.check_mesh_size``)."""
    if not (np.isfinite(factor) and factor > 0):
        raise ValueError(f"option {option} = {factor!r}: expected a positive scale factor on the element sizes")
    scaled = scaled_sizes(sizes, factor)
    try:
        for beam in beams:
            check_mesh_size(beam, scaled)
    except GeometryError as error:
        raise ValueError(f"option {option} = {factor!r}: {error}") from None
    return scaled


def dynamic_matrices(beam_mesh: BeamMesh, beam: BeamParameters, material: Material = Material(),
                     bolt: Bolt = Bolt()) -> tuple[MeshTet, sp.csr_matrix, sp.csr_matrix]:
    """The solid mesh, its stiffness K (n_dof, n_dof) N/m and the mass M of the solid plus the bolt masses, kg."""
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    mass = mass_matrix(mesh, material) + bolts_mass(washer_couplings(mesh, beam_mesh, beam), bolt)
    return mesh, stiffness_matrix(mesh, material), mass.tocsr()


def first_bending(frequencies: np.ndarray, shapes: np.ndarray, n_rigid: int = 6) -> int:
    """Index of the first out-of-plane bending mode: the first elastic mode (after ``n_rigid``) whose z
    displacements dominate, |u_z| > 3 |u_y| and |u_z| > |u_x| (norms over all nodes).

    frequencies: (n_modes,) Hz ascending; shapes: (3 n_nodes, n_modes). Raises ValueError when none is found.
    """
    for index in range(n_rigid, len(frequencies)):
        norms = np.linalg.norm(shapes[:, index].reshape(-1, 3), axis=0)
        if norms[2] > 3 * norms[1] and norms[2] > norms[0]:
            return index
    raise ValueError(f"no out-of-plane bending mode among the {len(frequencies)} modes solved")


def tied_first_bending(beam_mesh: BeamMesh, beam: BeamParameters, material: Material = Material(),
                       bolt: Bolt = Bolt()) -> tuple[int, float]:
    """(n_dof of the two halves, first out-of-plane bending frequency Hz) with the lap tied, bolt masses included."""
    mesh, stiffness, mass = dynamic_matrices(beam_mesh, beam, material, bolt)
    tie = tie_transformation(stiffness.shape[0], *interface_quadratic_pairs(mesh, *interface_partners(beam_mesh)))
    frequencies, shapes = tied_modes(stiffness, mass, tie, N_MODES)
    return stiffness.shape[0], float(frequencies[first_bending(frequencies, shapes)])


def changes_to_finer(frequencies: np.ndarray) -> np.ndarray:
    """Relative change f_i / f_(i+1) - 1 of each mesh to the next finer one; NaN for the finest. (n,) -> (n,)."""
    frequencies = np.asarray(frequencies, dtype=float)
    return np.append(frequencies[:-1] / frequencies[1:] - 1, np.nan)


def converged_index(frequencies: np.ndarray, tolerance: float = TOLERANCE) -> int | None:
    """Index of the coarsest mesh whose frequency differs by less than ``tolerance`` (relative) from that of every
    finer mesh of the study: its change to the next finer mesh is below the tolerance, and so is its distance to
    the finest, so that a slowly converging sequence of small steps does not pass. None if only the finest does.

    frequencies: (n,) Hz, coarse to fine.
    """
    frequencies = np.asarray(frequencies, dtype=float)
    for index in range(len(frequencies) - 1):
        if np.all(np.abs(frequencies[index] / frequencies[index + 1:] - 1) < tolerance):
            return index
    return None


def convergence_study(beam: BeamParameters, sizes: MeshParameters, factors, material: Material = Material(),
                      bolt: Bolt = Bolt(), progress: bool = False) -> list[dict]:
    """Mesh ``beam`` at ``sizes`` scaled by each factor (coarse to fine) and solve the tied first bending.

    Returns one row per factor with the keys of ``COLUMNS``: sizes m, DOF, frequency Hz, relative change to the
    next finer mesh, and the wall time s of meshing plus solving.
    """
    rows = []
    with tempfile.TemporaryDirectory(prefix="fe-convergence-") as folder:
        for factor in tqdm(factors, desc=f"{beam.name} meshes", unit="mesh", disable=not progress):
            start = time.perf_counter()
            scaled = scaled_sizes(sizes, factor)
            sidecar = make_beam(beam, scaled, Path(folder) / f"{factor:g}", render=False)
            dof, frequency = tied_first_bending(read_beam_mesh(sidecar.with_suffix(".msh"), beam), beam, material, bolt)
            rows.append({"factor": factor, "size_m": scaled.size, "lap_size_m": scaled.lap_size,
                         "hole_size_m": scaled.hole_size, "dof": dof, "first_bending_hz": frequency,
                         "seconds": time.perf_counter() - start})
            if progress:
                tqdm.write(f"s = {factor:g}: {dof} DOF, {frequency:.3f} Hz, {rows[-1]['seconds']:.0f} s")
    for row, change in zip(rows, changes_to_finer([row["first_bending_hz"] for row in rows])):
        row["change_to_finer"] = change
    return rows


def write_table(rows: list[dict], path: Path) -> None:
    """The study as CSV (``COLUMNS``; units in the names), atomically."""
    with atomic_path(path) as temporary:
        with open(temporary, "w", newline="") as stream:
            writer = csv.DictWriter(stream, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(rows)


def study_record(beam: BeamParameters, sizes: MeshParameters, material: Material, rows: list[dict],
                 tolerance: float = TOLERANCE) -> dict:
    """The JSON sidecar of a study: inputs, the table's name and the converged mesh (``converged_index``)."""
    chosen = converged_index([row["first_bending_hz"] for row in rows], tolerance)
    factor = None if chosen is None else rows[chosen]["factor"]
    return {"beam": dataclasses.asdict(beam), "base_mesh": dataclasses.asdict(sizes),
            "factors": [row["factor"] for row in rows], "material": dataclasses.asdict(material),
            "bolt_mass_included": True, "tolerance": tolerance, "table": f"{beam.name}.csv",
            "converged_factor": factor, "converged_dof": None if chosen is None else rows[chosen]["dof"],
            "converged_mesh": None if chosen is None else dataclasses.asdict(scaled_sizes(sizes, factor))}


def check_study_inputs(beam: BeamParameters, sizes: MeshParameters, factors, tolerance: float) -> None:
    """Refuse, before any mesh is made, a study that cannot run: a ``tolerance`` (relative) outside (0, 1), a
    factor that is not a positive mesh-size factor below 100, or one whose element sizes would not fit in memory on
    ``beam`` (``check_mesh_factor``). Raises ValueError naming the option as typed."""
    if not 0.0 < tolerance < 1.0:
        raise ValueError(f"option --tolerance = {tolerance!r}: expected a relative change in (0, 1)")
    if not all(0.0 < factor < 100.0 for factor in factors):
        raise ValueError(f"option --factors = {factors}: expected positive mesh-size factors below 100")
    for factor in factors:
        check_mesh_factor("--factors", factor, [beam], sizes)


def write_study(beam: BeamParameters, sizes: MeshParameters, factors, out: Path, material: Material = Material(),
                tolerance: float = TOLERANCE, progress: bool = False) -> tuple[Path, dict]:
    """The convergence study of ``beam`` at ``sizes`` scaled by each factor, coarse to fine (``convergence_study``),
    written to ``<out>/<beam>.csv`` (``write_table``) and its record to ``<out>/<beam>.json`` (``study_record``: the
    mesh converged within ``tolerance``, relative). Its inputs and the folder ``out`` are checked before any mesh
    is made (``check_study_inputs``; the table is written after every mesh is solved). Returns the table's path and
    the record."""
    check_study_inputs(beam, sizes, factors, tolerance)
    check_output_folder(out)
    rows = convergence_study(beam, sizes, sorted(factors, reverse=True), material, progress=progress)
    table = Path(out) / f"{beam.name}.csv"
    write_table(rows, table)
    record = study_record(beam, sizes, material, rows, tolerance)
    write_json(table.with_suffix(".json"), record)
    return table, record
