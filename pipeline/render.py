"""Off-screen PyVista plumbing that the stages' renders share: the EGL render window, and the tetrahedral grid
and triangle surfaces of a beam mesh.

PyVista is imported inside the functions, so that the stages import without it; importing this module selects
the off-screen EGL window before VTK first loads.
"""

from __future__ import annotations

import os

import numpy as np

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def _cells(connectivity: np.ndarray) -> np.ndarray:
    """VTK's flat cell array: each row of ``connectivity`` (m, k) preceded by its node count k."""
    return np.hstack([np.full((len(connectivity), 1), connectivity.shape[1]), connectivity]).ravel()


def tetrahedral_grid(points: np.ndarray, tetrahedra: np.ndarray):
    """A pyvista UnstructuredGrid of linear tetrahedra drawn on the corners of a tetrahedral mesh.

    points: (n_nodes, 3) m; tetrahedra: (m, 4) or quadratic (m, 10) node indices, corners first (gmsh and
    scikit-fem order); only the four corners are used, so a quadratic mesh is drawn with straight edges.
    """
    import pyvista

    corners = tetrahedra[:, :4]
    cell_types = np.full(len(corners), pyvista.CellType.TETRA, dtype=np.uint8)
    return pyvista.UnstructuredGrid(_cells(corners), cell_types, points)


def triangle_surface(points: np.ndarray, triangles: np.ndarray):
    """A pyvista PolyData of the triangles (m, 3) or quadratic (m, 6), corners first, over points (n_nodes, 3) m;
    only the three corners are used."""
    import pyvista

    return pyvista.PolyData(points, faces=_cells(triangles[:, :3]))
