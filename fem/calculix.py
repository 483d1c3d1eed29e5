"""Independent cross-check with CalculiX (``ccx``, Debian package calculix-ccx): input decks from our meshes.

The deck holds the same straight-sided quadratic tetrahedra as the scikit-fem model (C3D10, Abaqus/CalculiX
node order: corners 1-4, then the mid-side nodes of edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4; docs/design.md section 3.1), the
same material and the same tie: every upper interface node is merged into its lower partner, which is exactly
the DOF identification of ``fem.modes.tie_transformation``.

The preload deck (``preload_contact_deck``) solves the prestress step of ``fem.contact`` independently: the two
halves unmerged, frictionless hard contact on the lap, each bolt a preloaded axial spring between two reference
nodes joined to the washer footprints by distributing couplings (DCOUP3D; docs/design.md section 3.1), and a load-free
support. Contact is node-to-surface (upper interface nodes against the lower interface faces): on this conforming
interface every slave node sits on a master node, so the constraint is our node-pair constraint up to the
penalty. Surface-to-surface contact integrates the pressure over the six-node slave faces instead (negative
corner forces, a different nodal split of the same load), and took 3 times the iterations on the coarse BRB.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
from skfem import MeshTet

from .bolts import Bolt, quadratic_triangles
from .coupling import nodal_areas
from .elasticity import Material, edge_indices, quadratic_node_coordinates

# Corner pairs of the six mid-side nodes of a C3D10 element, in its node order (0-based corners).
C3D10_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
# Corners of the faces S1-S4 of a C3D4/C3D10 element (0-based, CalculiX manual, tetrahedral faces).
C3D10_FACES = ((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0))


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
    return (node_cards(kept + 1, coordinates[kept]) + solid_cards(elements, material)
            + f"*STEP\n*FREQUENCY\n{n_modes}\n*END STEP\n")


def node_cards(ids: np.ndarray, coordinates: np.ndarray) -> str:
    """``*NODE`` lines for node ids (n,) at coordinates (n, 3) m; ccx reads at most 20 characters per number: 14
    significant digits."""
    return "*NODE\n" + "".join(f"{i}, {x:.14g}, {y:.14g}, {z:.14g}\n" for i, (x, y, z) in zip(ids, coordinates))


def solid_cards(elements: np.ndarray, material: Material) -> str:
    """C3D10 elements 1..n (node ids (n, 10), ``c3d10_connectivity`` order) in ELSET=SOLID, with the material
    (Pa, kg/m^3) and section."""
    cells = "".join(f"{i + 1}, " + ", ".join(map(str, row)) + "\n" for i, row in enumerate(elements))
    return (f"*ELEMENT, TYPE=C3D10, ELSET=SOLID\n{cells}"
            f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{material.youngs_modulus:.14g}, {material.poissons_ratio:.14g}\n"
            f"*DENSITY\n{material.density:.14g}\n*SOLID SECTION, ELSET=SOLID, MATERIAL=STEEL\n")


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


def element_faces(connectivity: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The element and face (1-4, S1-S4 of ``C3D10_FACES``) holding each boundary triangle.

    connectivity: (n_elements, >=4) ``c3d10_connectivity``; triangles: (m, >=3) vertex indices (corners first).
    Returns 0-based element indices (m,) and face numbers (m,). Raises KeyError for a triangle on no element.
    """
    owner = {}
    for face, corners in enumerate(C3D10_FACES, start=1):
        for element, vertices in enumerate(np.sort(connectivity[:, list(corners)], axis=1)):
            owner[tuple(vertices)] = (element, face)
    found = np.array([owner[tuple(vertices)] for vertices in np.sort(triangles[:, :3], axis=1)]).reshape(-1, 2)
    return found[:, 0], found[:, 1]


def bolt_elongations(couplings: list, displacement: np.ndarray) -> np.ndarray:
    """Change of the distance between each bolt's washer reference points along the bolt axis z, (n_bolts,) m
    (negative: the clamped stack shortens). couplings: ``fem.bolts.washer_couplings``; displacement: (n_dof,) m."""
    return np.array([((upper[2] - lower[2]) @ displacement).item() for lower, upper in couplings])


def spring_initial_forces(bolt: Bolt, elongations: np.ndarray) -> np.ndarray:
    """Force N at zero elongation of a preloaded axial spring of stiffness E A / L that carries exactly the preload
    once the bolt has elongated by ``elongations`` (n_bolts,) m: F0 = P - (E A / L) e, (n_bolts,) N.

    With the elongations of our pretension solve (``bolt_elongations``) a spring of the bolt's own axial
    stiffness clamps with exactly P in a model as compliant as ours: the spring force then checks the compliance.
    """
    return bolt.preload - bolt.axial_stiffness * np.asarray(elongations)


def in_plane_support(supported: np.ndarray) -> np.ndarray:
    """The in-plane DOFs (3,) of a ``fem.contact.support_321`` set: x, y of its first vertex and y of its second.

    On the upper half they hold in-plane rigid motion, which frictionless contact leaves free, without load: the
    preload and the contact forces have no in-plane resultant on that half.
    """
    return np.asarray(supported)[[0, 1, 3]]


def preload_contact_deck(mesh: MeshTet, beam_mesh, beam, material: Material, bolt: Bolt,
                         initial_forces: np.ndarray, supported: np.ndarray, penalty: float = 1e17,
                         tension: float = 1e3) -> str:
    """A CalculiX ``*STATIC`` deck of the bolt preload with frictionless node-to-surface contact on the lap.

    mesh: straight-sided tetrahedra of both halves (no merged nodes; node ids = quadratic node index + 1);
    beam_mesh: ``geometry.beam_mesh.BeamMesh`` (faces ``{side}_interface``, ``{side}_washer_{b}``); beam:
    ``geometry.parameters.BeamParameters``; initial_forces: (n_bolts,) N, spring force at zero elongation
    (``spring_initial_forces``); supported: DOF indices (3 node + component) held at zero.

    Each bolt: reference nodes on the axis (x = bolt_x, y = 0) at z = -H/2 and +H/2 (those of
    ``fem.bolts.washer_couplings``), each a DCOUP3D distributing coupling over its washer footprint weighted by the
    same consistent nodal areas, joined by a SPRINGA of stiffness E A / L whose force is F0 + (E A / L) e.
    Contact: slave = upper interface faces, master = lower; ``*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=HARD``, which
    ccx makes a linear penalty for node-to-surface contact: penalty N/m^3 (a node's contact spring K a_i, about
    1e17 x 1.5e-6 m^2 on the coarse BRB, is 250 times the solid's E h = 6e8 N/m there; 1e18 does not converge) and
    tension Pa, the pull ccx requires at large clearances (its default, 2.7 MPa here, stiffens the joint visibly;
    1e3 Pa on the open lap ends pulls with about 1 N in all, 3e-5 of the clamp).
    Prints the displacements (``*NODE PRINT``) of node sets SOLID_NODES (every mesh node) and REFERENCES (lower, upper
    reference node of bolt 1, then bolt 2, ...). SI units.
    """
    coordinates = quadratic_node_coordinates(mesh)
    n_nodes = len(coordinates)
    connectivity = c3d10_connectivity(mesh)
    references = np.array([[x, 0.0, z] for x in beam.bolt_x for z in (-beam.height / 2, beam.height / 2)])
    reference_ids = n_nodes + 1 + np.arange(len(references))
    cards = [node_cards(np.arange(1, n_nodes + 1), coordinates), node_cards(reference_ids, references),
             f"*NSET, NSET=SOLID_NODES, GENERATE\n1, {n_nodes}, 1\n*NSET, NSET=REFERENCES\n"
             + ", ".join(map(str, reference_ids)) + "\n", solid_cards(connectivity + 1, material)]
    element = len(connectivity)
    for index, (side, number) in enumerate((side, b) for b in range(1, len(beam.bolt_x) + 1)
                                           for side in ("lower", "upper")):
        element += 1
        weights = nodal_areas(coordinates, quadratic_triangles(mesh, beam_mesh.faces[f"{side}_washer_{number}"]))
        footprint = np.flatnonzero(weights)
        cards.append(f"*ELEMENT, TYPE=DCOUP3D, ELSET=WASHER{index + 1}\n{element}, {reference_ids[index]}\n"
                     f"*DISTRIBUTING COUPLING, ELSET=WASHER{index + 1}\n"
                     + "".join(f"{node + 1}, {weights[node]:.14g}\n" for node in footprint))
    stiffness, span = bolt.axial_stiffness, 1e-3  # force-elongation table over +-1 mm (the stack moves by um)
    for b, force in enumerate(initial_forces, start=1):
        element += 1
        cards.append(f"*ELEMENT, TYPE=SPRINGA, ELSET=SHANK{b}\n{element}, {reference_ids[2 * b - 2]}, "
                     f"{reference_ids[2 * b - 1]}\n*SPRING, ELSET=SHANK{b}, NONLINEAR\n"
                     f"{force - stiffness * span:.14g}, {-span:.14g}\n{force + stiffness * span:.14g}, {span:.14g}\n")
    for side in ("lower", "upper"):
        elements, faces = element_faces(connectivity, beam_mesh.faces[f"{side}_interface"])
        cards.append(f"*SURFACE, NAME={side.upper()}_LAP, TYPE=ELEMENT\n"
                     + "".join(f"{e + 1}, S{f}\n" for e, f in zip(elements, faces)))
    cards.append(f"*SURFACE INTERACTION, NAME=LAP\n*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=HARD\n"
                 f"{penalty:.6g}, {tension:.6g}\n"
                 "*CONTACT PAIR, INTERACTION=LAP, TYPE=NODE TO SURFACE\nUPPER_LAP, LOWER_LAP\n*BOUNDARY\n"
                 + "".join(f"{dof // 3 + 1}, {dof % 3 + 1}, {dof % 3 + 1}, 0\n" for dof in supported)
                 + "*STEP\n*STATIC\n*NODE PRINT, NSET=SOLID_NODES\nU\n*NODE PRINT, NSET=REFERENCES\nU\n*END STEP\n")
    return "".join(cards)


def read_node_values(dat: Path, quantity: str, node_set: str) -> tuple[np.ndarray, np.ndarray]:
    """Node ids (n,) and values (n, 3) of the last ``*NODE PRINT`` table of ``quantity`` (its heading's first word,
    e.g. "displacements") for ``node_set`` in a ccx ``.dat`` file."""
    lines = Path(dat).read_text().splitlines()
    heading = f"{quantity} ("
    start = max(i for i, line in enumerate(lines)
                if line.strip().startswith(heading) and f"for set {node_set.upper()} " in line)
    rows = []
    for line in lines[start + 1:]:
        fields = line.split()
        if rows and not fields:
            break
        if fields:
            rows.append(fields)
    table = np.array(rows, dtype=float)
    return table[:, 0].astype(np.int64), table[:, 1:]
