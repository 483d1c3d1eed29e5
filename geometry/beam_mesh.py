"""The in-memory beam mesh that later stages read: nodes, tetrahedra per half, triangles per named face.

``read_beam_mesh`` reads a ``.msh`` written by the geometry stage (gmsh 4.1, physical groups named as in
geometry/brake_reuss.py) and numbers the nodes 0..n-1 in gmsh's tag order.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from .brake_reuss import gmsh_session, physical_group_names
from .parameters import BeamParameters

# gmsh element types: 4-node and 10-node tetrahedra, 3-node and 6-node triangles.
_TETRAHEDRA = {4: 4, 11: 10}
_TRIANGLES = {2: 3, 9: 6}


class MeshFileError(ValueError):
    """A mesh file is missing, unreadable or lacks what the pipeline needs."""


@dataclass(frozen=True)
class BeamMesh:
    """A meshed Brake-Reuss beam.

    points: (n_nodes, 3) node coordinates, m.
    volumes: group name (``lower_half``, ``upper_half``) -> (n_tetrahedra, 4 or 10) node indices (gmsh order).
    faces: group name (``lower_patch_1``, ``upper_washer_2``, ...) -> (n_triangles, 3 or 6) node indices.
    """

    points: np.ndarray
    volumes: dict[str, np.ndarray]
    faces: dict[str, np.ndarray]

    @property
    def tetrahedra(self) -> np.ndarray:
        """All tetrahedra of both halves, (n_tetrahedra, 4 or 10), lower half first."""
        return np.vstack([self.volumes[name] for name in sorted(self.volumes)])

    def face_nodes(self, name: str) -> np.ndarray:
        """Sorted unique node indices of a named face group."""
        return np.unique(self.faces[name])


def _group_elements(dim: int, tag: int, kinds: dict[int, int], index_of_tag: np.ndarray) -> np.ndarray:
    import gmsh

    blocks = []
    for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        types, _, node_tags = gmsh.model.mesh.getElements(dim, entity)
        for element_type, nodes in zip(types, node_tags):
            if element_type in kinds:
                blocks.append(index_of_tag[np.asarray(nodes, dtype=np.int64)].reshape(-1, kinds[element_type]))
    return np.vstack(blocks) if blocks else np.empty((0, 3), dtype=np.int64)


def read_beam_mesh(path: Path, beam: BeamParameters | None = None) -> BeamMesh:
    """Read a beam mesh written by the geometry stage. Raises MeshFileError naming the file and what is wrong.

    beam: the parameters the mesh was made from; given, every physical group of ``physical_group_names(beam)``
    (patches, washers, hole walls) must be present and non-empty, so that a renamed or missing group is named
    here instead of surfacing as a KeyError deep in the FE or reduction stage. Without it only the two halves
    and the two interfaces are required.
    """
    path = Path(path)
    if not path.is_file():
        raise MeshFileError(f"{path}: mesh file not found (run `make beams` first)")
    import gmsh

    with gmsh_session():
        try:
            gmsh.open(str(path))
        except Exception as error:  # gmsh raises a bare Exception with its own message
            raise MeshFileError(f"{path}: not a readable gmsh file ({error})") from None
        node_tags, coordinates, _ = gmsh.model.mesh.getNodes()
        if node_tags.size == 0:
            raise MeshFileError(f"{path}: no nodes (an empty or truncated mesh file; a mesh of the geometry stage "
                                "has them all); rerun make beams")
        order = np.argsort(node_tags)
        index_of_tag = np.full(int(node_tags.max()) + 1, -1, dtype=np.int64)
        index_of_tag[node_tags[order]] = np.arange(len(order))
        points = coordinates.reshape(-1, 3)[order]
        volumes, faces = {}, {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, tag)
            if dim == 3:
                volumes[name] = _group_elements(dim, tag, _TETRAHEDRA, index_of_tag)
            elif dim == 2:
                faces[name] = _group_elements(dim, tag, _TRIANGLES, index_of_tag)
    required = ("lower_half", "upper_half", "lower_interface", "upper_interface") if beam is None else \
        physical_group_names(beam)
    for name in required:
        group = volumes.get(name) if name.endswith("half") else faces.get(name)
        if group is None or len(group) == 0:
            raise MeshFileError(f"{path}: physical group '{name}' missing or empty (a mesh of the geometry stage "
                                "names every group it needs; rerun make beams)")
    return BeamMesh(points=points, volumes=volumes, faces=faces)


def interface_partners(mesh: BeamMesh, tolerance: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Pair every lower interface node with the upper interface node at the same position.

    Returns (lower, upper): node index arrays of equal length, lower sorted. Raises MeshFileError when a node
    has no partner within ``tolerance`` (m) or the two sides have different node counts.
    """
    lower, upper = mesh.face_nodes("lower_interface"), mesh.face_nodes("upper_interface")
    if len(lower) != len(upper):
        raise MeshFileError(f"interface not conforming: {len(lower)} lower vs {len(upper)} upper nodes")
    distance, nearest = cKDTree(mesh.points[upper]).query(mesh.points[lower])
    if distance.max() > tolerance or len(np.unique(nearest)) != len(lower):
        raise MeshFileError(f"interface not conforming: a node's partner is {distance.max():.3e} m away")
    return lower, upper[nearest]
