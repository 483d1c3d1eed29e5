"""gmsh (OpenCASCADE) model of a Brake-Reuss beam: two bolted stepped halves with a conforming lap interface.

Each half is built from its named parameters (geometry/parameters.py): a full-section body, a half-thickness lap,
three through holes, washer footprints (annuli from the hole edge to the washer's outer diameter) on the outer
face of the lap, and the interface face cut into patches at the lap-length fractions ``patch_cuts``. The upper
half is the lower one rotated 180 degrees about the y axis. The two halves are separate bodies: their
interface faces coincide but are not fused, and each upper patch is meshed as an identity copy of the lower one
(gmsh periodic constraint), so every interface node has a partner at exactly the same position.

Physical groups (names used by every later stage), for side in {lower, upper}:
  3D  ``{side}_half``
  2D  ``{side}_interface`` (all patches), ``{side}_patch_{p}`` p = 1..5 numbered with increasing x,
      ``{side}_washer_{b}`` and ``{side}_hole_wall_{b}`` b = 1..3 numbered with increasing bolt x.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

import gmsh

from .parameters import BeamParameters, MeshParameters

SIDES = ("lower", "upper")
_TOLERANCE = 1e-6  # m, for locating faces by their bounding boxes (OCC pads boxes by ~1e-7)
_IDENTITY = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0]


def physical_group_names(beam: BeamParameters) -> list[str]:
    """Every physical group the model of ``beam`` carries (module docstring), lower side first: the names the
    later stages look up, so a mesh file can be checked for all of them before it is used."""
    per_side = ["half", "interface", *(f"patch_{p}" for p in range(1, len(beam.patch_bounds) + 1)),
                *(f"{kind}_{b}" for b in range(1, len(beam.bolt_x) + 1) for kind in ("washer", "hole_wall"))]
    return [f"{side}_{name}" for side in SIDES for name in per_side]


def _restore_handlers(handlers: dict) -> None:
    """Install again the Python signal handlers ``handlers`` (signal number -> handler), in the main thread only
    (where Python handles signals); a signal whose handler was not set from Python (None) is left alone."""
    if threading.current_thread() is not threading.main_thread():
        return
    for number, handler in handlers.items():
        if handler is not None:
            signal.signal(number, handler)


@contextmanager
def gmsh_session():
    """An initialised, quiet, single-threaded (hence deterministic) gmsh session, finalised on exit.

    Initialised with ``interruptible=False``: by default gmsh's Python API resets SIGINT to the operating system's
    default action and never restores it. gmsh's library also resets SIGTERM to its default action as it
    initialises, so that a SIGTERM would kill the process outright (no clean-up of temporary files, not exit 143,
    no run log). Python's handlers of both signals are installed again right after; a signal during a gmsh call
    takes effect when that call returns.
    """
    handlers = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    _restore_handlers(handlers)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.RandomSeed", 1)
        yield gmsh
    finally:
        gmsh.finalize()


def _half(beam: BeamParameters, side: str) -> int:
    """Build one half's solid in the OCC kernel; returns its volume tag.

    The upper half is the lower one rotated 180 degrees about the y axis, but it is built directly (x and z
    mirrored) rather than copied and rotated: that keeps the seams of the OCC circles at the same +x point on
    both halves, which the identity mesh copy between the interface patches needs.
    """
    occ = gmsh.model.occ
    sign = -1.0 if side == "lower" else 1.0
    lap, width, height = beam.lap_length, beam.width, beam.height
    body_start = min(sign * lap / 2, sign * (lap / 2 + beam.body_length))
    body = occ.addBox(body_start, -width / 2, -height / 2, beam.body_length, width, height)
    lap_box = occ.addBox(-lap / 2, -width / 2, min(0.0, sign * height / 2), lap, width, beam.lap_thickness)
    half, _ = occ.fuse([(3, body)], [(3, lap_box)])
    if beam.spring_height is not None:
        notch_depth = (height - beam.spring_height) / 2
        notch_centre = sign * (lap / 2 + beam.spring_offset)
        notches = [(3, occ.addBox(notch_centre - beam.spring_length / 2, -width / 2, z, beam.spring_length, width,
                                  notch_depth)) for z in (-height / 2, height / 2 - notch_depth)]
        half, _ = occ.cut(half, notches)
    radius, washer_radius = beam.hole_diameter / 2, beam.washer_outer_diameter / 2
    outer_z = sign * height / 2
    holes = [(3, occ.addCylinder(x, 0, min(0.0, outer_z), 0, 0, beam.lap_thickness, radius)) for x in beam.bolt_x]
    half, _ = occ.cut(half, holes)
    annuli = []
    for x in beam.bolt_x:
        washer_disk = occ.addDisk(x, 0, outer_z, washer_radius, washer_radius)
        hole_disk = occ.addDisk(x, 0, outer_z, radius, radius)
        annulus, _ = occ.cut([(2, washer_disk)], [(2, hole_disk)])
        annuli += annulus
    cut_lines = []
    for lower, _upper in beam.patch_bounds[1:]:
        start = occ.addPoint(lower, -width / 2, 0)
        end = occ.addPoint(lower, width / 2, 0)
        cut_lines.append((1, occ.addLine(start, end)))
    pieces, _ = occ.fragment(half, annuli + cut_lines)
    (volume,) = [tag for dim, tag in pieces if dim == 3]
    return volume


def _faces_in_box(volume: int, box: tuple[float, ...]) -> list[int]:
    """Boundary faces of ``volume`` whose bounding box lies inside ``box`` (xmin, ymin, zmin, xmax, ymax, zmax)."""
    faces = []
    for _, face in gmsh.model.getBoundary([(3, volume)], oriented=False):
        bounds = gmsh.model.getBoundingBox(2, face)
        if all(bounds[i] >= box[i] - _TOLERANCE for i in range(3)) and \
                all(bounds[i] <= box[i] + _TOLERANCE for i in range(3, 6)):
            faces.append(face)
    return sorted(faces)


def _named_faces(beam: BeamParameters, volume: int, outer_z: float) -> dict[str, list[int]]:
    """Face tags of one half's patches, washer footprints and hole walls, keyed by group name without side.

    outer_z: z of the half's outer lap face (where the washers sit), m.
    """
    half_width = beam.width / 2
    groups = {}
    for p, (lower, upper) in enumerate(beam.patch_bounds, start=1):
        groups[f"patch_{p}"] = _faces_in_box(volume, (lower, -half_width, 0, upper, half_width, 0))
    washer_radius, hole_radius = beam.washer_outer_diameter / 2, beam.hole_diameter / 2
    z_low, z_high = sorted((0.0, outer_z))
    for b, x in enumerate(sorted(beam.bolt_x), start=1):
        groups[f"washer_{b}"] = _faces_in_box(
            volume, (x - washer_radius, -washer_radius, outer_z, x + washer_radius, washer_radius, outer_z))
        groups[f"hole_wall_{b}"] = _faces_in_box(
            volume, (x - hole_radius, -hole_radius, z_low, x + hole_radius, hole_radius, z_high))
    for name, faces in groups.items():
        if not faces:
            raise RuntimeError(f"gmsh model of {beam.name}: no face found for group '{name}'")
    return groups


def _refine(beam: BeamParameters, sizes: MeshParameters, hole_curves: list[int]) -> None:
    """Background size field: ``lap_size`` over the lap (and SBRB flexures), ``hole_size`` at the holes."""
    field = gmsh.model.mesh.field
    boxes = [(-beam.lap_length / 2, beam.lap_length / 2)]
    if beam.spring_height is not None:
        for sign in (-1, 1):
            centre = sign * (beam.lap_length / 2 + beam.spring_offset)
            boxes.append((centre - beam.spring_length / 2, centre + beam.spring_length / 2))
    fields = []
    for x_min, x_max in boxes:
        box = field.add("Box")
        for key, value in (("VIn", sizes.lap_size), ("VOut", sizes.size), ("XMin", x_min - sizes.lap_size),
                           ("XMax", x_max + sizes.lap_size), ("YMin", -beam.width), ("YMax", beam.width),
                           ("ZMin", -beam.height), ("ZMax", beam.height), ("Thickness", 2 * sizes.size)):
            field.setNumber(box, key, value)
        fields.append(box)
    distance = field.add("Distance")
    field.setNumbers(distance, "CurvesList", hole_curves)
    field.setNumber(distance, "Sampling", 60)
    threshold = field.add("Threshold")
    for key, value in (("InField", distance), ("SizeMin", sizes.hole_size), ("SizeMax", sizes.size),
                       ("DistMin", 0.0), ("DistMax", beam.washer_outer_diameter / 2)):
        field.setNumber(threshold, key, value)
    fields.append(threshold)
    minimum = field.add("Min")
    field.setNumbers(minimum, "FieldsList", fields)
    field.setAsBackgroundMesh(minimum)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)


def build_beam_mesh(beam: BeamParameters, sizes: MeshParameters) -> dict[str, tuple[int, list[int]]]:
    """Build, tag and mesh the beam in the current gmsh session.

    Returns the physical groups: name -> (dimension, entity tags). The mesh stays in the session for writing.
    """
    gmsh.model.add(beam.name)
    lower, upper = _half(beam, "lower"), _half(beam, "upper")
    gmsh.model.occ.synchronize()

    groups: dict[str, tuple[int, list[int]]] = {}
    hole_curves = []
    for side, volume, outer_z in (("lower", lower, -beam.height / 2), ("upper", upper, beam.height / 2)):
        groups[f"{side}_half"] = (3, [volume])
        faces = _named_faces(beam, volume, outer_z)
        patches = [tag for p in range(1, len(beam.patch_bounds) + 1) for tag in faces[f"patch_{p}"]]
        groups[f"{side}_interface"] = (2, patches)
        groups.update({f"{side}_{name}": (2, tags) for name, tags in faces.items()})
        for b in range(1, len(beam.bolt_x) + 1):
            walls = [(2, tag) for tag in faces[f"hole_wall_{b}"]]
            hole_curves += [tag for _, tag in gmsh.model.getBoundary(walls, combined=False, oriented=False)]
    for name, (dim, tags) in groups.items():
        gmsh.model.addPhysicalGroup(dim, tags, name=name)

    for p in range(1, len(beam.patch_bounds) + 1):
        gmsh.model.mesh.setPeriodic(2, groups[f"upper_patch_{p}"][1], groups[f"lower_patch_{p}"][1], _IDENTITY)
    _refine(beam, sizes, sorted(set(hole_curves)))
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)
    gmsh.option.setNumber("Mesh.SecondOrderLinear", 1)
    gmsh.model.mesh.generate(3)
    if sizes.order == 2:
        gmsh.model.mesh.setOrder(2)
    return groups


def write_msh(path: str) -> None:
    """Write the session's mesh as ASCII gmsh 4.1, physical groups only (volumes and named faces)."""
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.write(path)


def cad_measures(groups: dict[str, tuple[int, list[int]]]) -> dict[str, float]:
    """Exact CAD measure of each physical group: volume (m^3) of a 3D group, area (m^2) of a 2D group."""
    return {name: sum(gmsh.model.occ.getMass(dim, tag) for tag in tags) for name, (dim, tags) in groups.items()}
