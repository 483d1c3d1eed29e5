"""Independent cross-check with CalculiX (``ccx``, Debian package calculix-ccx): input decks from our meshes.

The deck holds the same straight-sided quadratic tetrahedra as the scikit-fem model (C3D10, Abaqus/CalculiX
node order: corners 1-4, then the mid-side nodes of edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4; DESIGN section 3.1), the
same material and the same tie: every upper interface node is merged into its lower partner, which is exactly
the DOF identification of ``fem.modes.tie_transformation``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
from skfem import MeshTet

from .elasticity import Material, edge_indices, quadratic_node_coordinates

# Corner pairs of the six mid-side nodes of a C3D10 element, in its node order (0-based corners).
C3D10_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))


def calculix_available() -> bool:
    """Whether the CalculiX solver ``ccx`` is on the PATH."""
    return shutil.which("ccx") is not None


def c3d10_connectivity(mesh: MeshTet) -> np.ndarray:
    """Quadratic-node indices of every element in C3D10 order, (n_elements, 10), positive volume orientation."""
    corners = mesh.t.T.copy()
    edge = mesh.p[:, corners[:, 1:]] - mesh.p[:, corners[:, [0]]]  # (3, n_elements, 3)
    inverted = np.einsum("ie,ie->e", np.cross(edge[:, :, 0], edge[:, :, 1], axis=0), edge[:, :, 2]) < 0
    corners[inverted] = corners[inverted][:, [0, 2, 1, 3]]
    n_vertices = mesh.p.shape[1]
    mid = [n_vertices + edge_indices(mesh, corners[:, a], corners[:, b]) for a, b in C3D10_EDGES]
    return np.column_stack([corners] + mid)


def tied_frequency_deck(mesh: MeshTet, material: Material, lower_nodes: np.ndarray, upper_nodes: np.ndarray,
                        n_modes: int) -> str:
    """A CalculiX ``*FREQUENCY`` deck of the free-free beam with upper interface nodes merged into their partners.

    lower_nodes, upper_nodes: partner quadratic nodes (``fem.modes.interface_quadratic_pairs``). Node ids are
    quadratic node index + 1. SI units (m, Pa, kg/m^3).
    """
    coordinates = quadratic_node_coordinates(mesh)
    representative = np.arange(len(coordinates))
    representative[upper_nodes] = lower_nodes
    elements = representative[c3d10_connectivity(mesh)] + 1
    kept = np.setdiff1d(np.arange(len(coordinates)), upper_nodes)
    # ccx reads at most 20 characters per number: 14 significant digits.
    nodes = "\n".join(f"{i + 1}, {x:.14g}, {y:.14g}, {z:.14g}" for i, (x, y, z) in zip(kept, coordinates[kept]))
    cells = "\n".join(f"{i + 1}, " + ", ".join(map(str, row)) for i, row in enumerate(elements))
    return (f"*NODE\n{nodes}\n*ELEMENT, TYPE=C3D10, ELSET=SOLID\n{cells}\n"
            f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{material.youngs_modulus:.14g}, {material.poissons_ratio:.14g}\n"
            f"*DENSITY\n{material.density:.14g}\n*SOLID SECTION, ELSET=SOLID, MATERIAL=STEEL\n"
            f"*STEP\n*FREQUENCY\n{n_modes}\n*END STEP\n")


def run_calculix(deck: str, folder: Path, name: str = "job") -> Path:
    """Write ``deck`` to folder/name.inp, run ``ccx`` there single-threaded; returns the .dat path.

    Raises RuntimeError with the tail of ccx's output when it fails.
    """
    folder = Path(folder)
    (folder / f"{name}.inp").write_text(deck)
    environment = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1")
    result = subprocess.run(["ccx", name], cwd=folder, capture_output=True, text=True, env=environment)
    dat = folder / f"{name}.dat"
    if result.returncode != 0 or "*ERROR" in result.stdout or not dat.is_file():
        raise RuntimeError(f"ccx failed in {folder}: {result.stdout[-2000:]}{result.stderr[-1000:]}")
    return dat


def read_frequencies(dat: Path) -> np.ndarray:
    """Natural frequencies (cycles/time, Hz) from the eigenvalue table of a ccx ``.dat`` file, ascending."""
    lines = Path(dat).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if "E I G E N V A L U E   O U T P U T" in line)
    frequencies = []
    for line in lines[start + 1:]:
        fields = line.split()
        if frequencies and not fields:
            break
        if len(fields) >= 4 and fields[0].isdigit():
            frequencies.append(float(fields[3]))
    return np.array(frequencies)
