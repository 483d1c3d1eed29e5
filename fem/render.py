"""Off-screen PyVista renders of the FE results: interface contact pressure (paper Fig. 7a) and the first bending
mode shape (paper Fig. 8).

Contact pressure. The preload solve (``fem.contact``) gives a normal force N_i on each interface node pair. The
pressure at node i is p_i = N_i / a_i with a_i the consistent nodal area of the six-node interface triangles
(``fem.coupling.nodal_areas``): A/3 at each mid-side node and zero at the corners, so p is defined at the
mid-side nodes, where it is exact for a uniform pressure. For the picture each six-node triangle is split into
its four three-node sub-triangles and a corner is shown with the mean pressure of the mid-side nodes of the
edges that meet there; the colour range is the range of the mid-side pressures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geometry.beam_mesh import BeamMesh
from pipeline.render import tetrahedral_grid, triangle_surface

from .bolts import quadratic_triangles
from .convergence import first_bending
from .coupling import nodal_areas
from .elasticity import solid_mesh
from .prestress import PrestressedBeam

PRESSURE_COLOURMAP = "viridis"
MODE_COLOURMAP = "jet"
SCALAR_BAR = {"color": "black", "vertical": True, "position_x": 0.88, "position_y": 0.15, "width": 0.06,
              "height": 0.7, "title_font_size": 20, "label_font_size": 18}
SUBTRIANGLES = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])  # of a six-node triangle (corners, 01, 12, 20)


def nodal_pressure(forces: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Contact pressure p_i = N_i / a_i, Pa, at the nodes of positive nodal area; NaN elsewhere.

    forces: (n_nodes,) normal contact force N (compressive positive); areas: (n_nodes,) consistent nodal areas m^2.
    """
    pressure = np.full(len(areas), np.nan)
    loaded = areas > 0
    pressure[loaded] = forces[loaded] / areas[loaded]
    return pressure


def corner_means(triangles: np.ndarray, pressure: np.ndarray) -> np.ndarray:
    """``pressure`` (n_nodes,) with each corner node of the six-node ``triangles`` (m, 6) set to the mean pressure of
    the mid-side nodes of its incident edges (corners have zero consistent area, so no pressure of their own)."""
    adjacent_midsides = triangles[:, [3, 5, 3, 4, 5, 4]].reshape(-1, 3, 2)  # corner 0: 01, 20; 1: 01, 12; 2: 20, 12
    totals, counts = np.zeros(len(pressure)), np.zeros(len(pressure))
    np.add.at(totals, triangles[:, :3], pressure[adjacent_midsides].sum(axis=2))
    np.add.at(counts, triangles[:, :3], 2)
    shown = pressure.copy()
    corners = np.unique(triangles[:, :3])
    shown[corners] = totals[corners] / counts[corners]
    return shown


def _look_down_on(plotter, bounds, window_size, fill: float = 0.72) -> None:
    """Parallel projection from +z onto the x-y rectangle ``bounds`` (xmin, xmax, ymin, ymax, ...), x to the right,
    the rectangle filling ``fill`` of the window's width left of the scalar bar."""
    centre = np.array([(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, 0.0])
    visible_width = (bounds[1] - bounds[0]) / fill
    centre[0] += 0.07 * visible_width  # room on the right for the vertical scalar bar
    plotter.enable_parallel_projection()
    plotter.camera_position = [tuple(centre + np.array([0.0, 0.0, 1.0])), tuple(centre), (0.0, 1.0, 0.0)]
    plotter.camera.parallel_scale = visible_width * window_size[1] / window_size[0] / 2


def render_contact_pressure(points: np.ndarray, triangles: np.ndarray, pressure: np.ndarray, path: Path,
                            title: str, window_size=(1600, 600)) -> tuple[float, float]:
    """Write a PNG of the interface seen from above (+z), coloured by contact pressure, Pa.

    points: (n_nodes, 3) quadratic node coordinates m; triangles: (m, 6) six-node interface triangles;
    pressure: (n_nodes,) Pa at the mid-side nodes (``nodal_pressure``). Returns the colour range (min, max), Pa:
    that of the mid-side pressures.
    """
    import pyvista

    midsides = np.unique(triangles[:, 3:])
    colour_range = (float(np.nanmin(pressure[midsides])), float(np.nanmax(pressure[midsides])))
    surface = triangle_surface(points, triangles[:, SUBTRIANGLES].reshape(-1, 3))
    surface.point_data["contact pressure, Pa"] = corner_means(triangles, pressure)
    plotter = pyvista.Plotter(off_screen=True, window_size=window_size)
    plotter.set_background("white")
    plotter.add_mesh(surface, scalars="contact pressure, Pa", cmap=PRESSURE_COLOURMAP, clim=colour_range,
                     lighting=False, scalar_bar_args={"title": "contact pressure, Pa\n", "fmt": "%.3g",
                                                      **SCALAR_BAR})
    outline = triangle_surface(points, triangles).extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False)
    plotter.add_mesh(outline, color="black", line_width=2)
    used = points[np.unique(triangles)]
    _look_down_on(plotter, np.column_stack([used.min(axis=0), used.max(axis=0)]).ravel(), window_size)
    plotter.add_text(title, font_size=12, color="black")
    plotter.screenshot(str(path))
    plotter.close()
    return colour_range


def render_mode_shape(points: np.ndarray, tetrahedra: np.ndarray, shape: np.ndarray, path: Path, title: str,
                      amplitude: float = 0.08, window_size=(1600, 900)) -> None:
    """Write a PNG of a mode shape: the deformed outer surface coloured by displacement magnitude (normalised),
    over the undeformed beam (translucent grey).

    points: (n_vertices, 3) m; tetrahedra: (m, 4) or (m, 10) node indices of both halves, corners first; shape:
    (3 n, ...) mode shape whose first 3 n_vertices entries are the vertex displacements (quadratic numbering,
    vertices first);
    amplitude: largest displayed displacement as a fraction of the beam length.
    """
    import pyvista

    displacement = shape[:3 * len(points)].reshape(-1, 3)
    magnitude = np.linalg.norm(displacement, axis=1)
    scale = amplitude * np.ptp(points[:, 0]) / magnitude.max()
    solid = tetrahedral_grid(points, tetrahedra)
    solid.point_data["displacement"] = displacement
    solid.point_data["displacement / max"] = magnitude / magnitude.max()
    surface = solid.extract_surface(algorithm="dataset_surface")
    plotter = pyvista.Plotter(off_screen=True, window_size=window_size)
    plotter.set_background("white")
    plotter.add_mesh(surface, color="lightgrey", opacity=0.25)
    plotter.add_mesh(surface.warp_by_vector("displacement", factor=scale), scalars="displacement / max",
                     cmap=MODE_COLOURMAP, clim=(0.0, 1.0),
                     scalar_bar_args={"title": "displacement / max\n", "fmt": "%.1f", **SCALAR_BAR})
    plotter.camera_position = [(0.35, -1.0, 0.45), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    plotter.reset_camera()
    plotter.camera.zoom(1.3)
    plotter.add_text(title, font_size=12, color="black")
    plotter.screenshot(str(path))
    plotter.close()


def interface_pressure(beam_mesh: BeamMesh, model: PrestressedBeam) -> tuple[np.ndarray, np.ndarray]:
    """The lower interface's six-node triangles (m, 6) and the preload's contact pressure (n_nodes,) Pa at their
    mid-side nodes (``nodal_pressure``; NaN elsewhere). The force N on an upper node presses its lower partner
    with -N: the same pressure on both faces."""
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    triangles = quadratic_triangles(mesh, beam_mesh.faces["lower_interface"])
    forces = np.zeros(len(model.coordinates))
    forces[model.lower_nodes] = model.contact.normal_force
    return triangles, nodal_pressure(forces, nodal_areas(model.coordinates, triangles))


def render_fe(beam_mesh: BeamMesh, model: PrestressedBeam, name: str, pressure_path: Path,
              mode_path: Path) -> tuple[float, float]:
    """Write the contact-pressure map (paper Fig. 7a) and the prestressed first bending mode (paper Fig. 8) of one
    beam. Returns the pressure colour range (min, max), Pa."""
    triangles, pressure = interface_pressure(beam_mesh, model)
    colour_range = render_contact_pressure(model.coordinates, triangles, pressure, pressure_path,
                                           f"{name}: contact pressure on the lower interface after preload "
                                           f"(frictionless, seen from +z)")
    mode = first_bending(model.prestressed_frequencies, model.prestressed_shapes)
    n_vertices = len(beam_mesh.points)
    render_mode_shape(model.coordinates[:n_vertices], beam_mesh.tetrahedra, model.prestressed_shapes[:, mode],
                      mode_path, f"{name}: first bending {model.prestressed_frequencies[mode]:.1f} Hz "
                                 f"(lap tied, prestressed)")
    return colour_range
