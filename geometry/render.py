"""Off-screen PyVista renders of a beam mesh, coloured by interface patch."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.render import tetrahedral_grid, triangle_surface

from .beam_mesh import BeamMesh


def _add_beam(plotter, mesh: BeamMesh, lift: float) -> None:
    from matplotlib import colormaps

    palette = colormaps["tab10"]
    patch_numbers = sorted({int(name.rsplit("_", 1)[1]) for name in mesh.faces if "_patch_" in name})
    for side, shift in (("lower", np.zeros(3)), ("upper", np.array([0.0, 0.0, lift]))):
        points = mesh.points + shift
        volume = tetrahedral_grid(points, mesh.volumes[f"{side}_half"])
        plotter.add_mesh(volume.extract_surface(algorithm="dataset_surface"), color="lightgrey", opacity=0.35,
                         show_edges=True, edge_color="grey", line_width=0.5)
        for p in patch_numbers:
            plotter.add_mesh(triangle_surface(points, mesh.faces[f"{side}_patch_{p}"]), color=palette(p - 1)[:3],
                             show_edges=True, edge_color="black", line_width=0.5,
                             label=f"patch {p}" if side == "lower" else None)
        for name in (n for n in mesh.faces if n.startswith(f"{side}_washer_")):
            plotter.add_mesh(triangle_surface(points, mesh.faces[name]), color="dimgrey")


def render_patches(mesh: BeamMesh, path: Path, title: str, window_size=(1600, 1200)) -> None:
    """Write a PNG of the beam, upper half lifted off the lower one so both interfaces show.

    Top view port: the whole beam; bottom: a close-up of the lap. Each half is translucent grey with its element
    edges; the interface patches are coloured by patch number (partner patches alike) and the washer
    footprints dark grey.
    """
    import pyvista

    height = np.ptp(mesh.points[:, 2])
    plotter = pyvista.Plotter(off_screen=True, window_size=window_size, shape=(2, 1), border=False)
    plotter.set_background("white")
    for row, zoom in ((0, 1.6), (1, 1.0)):
        plotter.subplot(row, 0)
        _add_beam(plotter, mesh, 1.5 * height)
        plotter.camera_position = "iso"
        if row == 1:
            interface = mesh.points[mesh.face_nodes("lower_interface")]
            plotter.camera.focal_point = interface.mean(axis=0)
            plotter.reset_camera(bounds=np.column_stack([interface.min(0), interface.max(0)]).ravel())
            plotter.add_legend(bcolor="white", face="rectangle", size=(0.15, 0.3))
        plotter.camera.zoom(zoom)
    plotter.subplot(0, 0)
    plotter.add_text(title, font_size=12, color="black")
    plotter.screenshot(str(path))
    plotter.close()
