"""Off-screen PyVista render of a mode of the superelement, expanded to the beam mesh."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geometry.beam_mesh import BeamMesh
from pipeline.render import tetrahedral_grid

DEFLECTION = 0.05  # the largest displacement drawn, as a fraction of the beam length


def render_mode(beam_mesh: BeamMesh, vertex_displacement: np.ndarray, path: Path, title: str,
                window_size=(1600, 700)) -> None:
    """Write a PNG of the beam deformed by a mode shape, coloured by displacement magnitude, over the undeformed
    outline.

    vertex_displacement: (n_vertices, 3) displacement of the mesh vertices (``vertex_recovery @ q``), any scale:
    drawn with its largest value at ``DEFLECTION`` times the beam length.
    """
    import pyvista

    points = beam_mesh.points[:len(vertex_displacement)]
    grid = tetrahedral_grid(points, beam_mesh.tetrahedra)
    magnitude = np.linalg.norm(vertex_displacement, axis=1)
    scale = DEFLECTION * np.ptp(points[:, 0]) / magnitude.max()
    grid.point_data["|u| (normalised)"] = magnitude / magnitude.max()
    deformed = grid.copy()
    deformed.points = points + scale * vertex_displacement
    plotter = pyvista.Plotter(off_screen=True, window_size=window_size)
    plotter.set_background("white")
    outline = grid.extract_surface(algorithm="dataset_surface").extract_feature_edges()
    plotter.add_mesh(outline, color="grey", line_width=1)
    plotter.add_mesh(deformed.extract_surface(algorithm="dataset_surface"), scalars="|u| (normalised)",
                     cmap="viridis", show_edges=False, scalar_bar_args={"color": "black"})
    plotter.camera_position = "xz"
    plotter.camera.elevation = 20
    plotter.camera.azimuth = -30
    plotter.reset_camera()
    plotter.camera.zoom(1.8)
    plotter.add_text(title, font_size=11, color="black")
    plotter.screenshot(str(path))
    plotter.close()
