"""Volumes and areas of a beam: analytic from its parameters, and measured on its mesh.

The analytic values are the independent reference for the meshes. Straight-sided elements replace each circular
hole by a polygon (on a face) or polyhedron (in the volume); ``hole_volume`` and ``hole_polygon_area`` measure
exactly that replacement, so mesh and analytic values can be compared to round-off rather than to a mesh-size
tolerance.
"""

from __future__ import annotations

import math

import numpy as np

from .parameters import BeamParameters


def hole_area(beam: BeamParameters) -> float:
    """Cross-section area of one bolt hole, m^2."""
    return math.pi * beam.hole_diameter ** 2 / 4


def solid_half_volume(beam: BeamParameters) -> float:
    """Volume of one half without its bolt holes, m^3: body + half-thickness lap - SBRB flexure notches."""
    volume = beam.body_length * beam.width * beam.height + beam.lap_length * beam.width * beam.lap_thickness
    if beam.spring_height is not None:
        volume -= beam.spring_length * beam.width * (beam.height - beam.spring_height)
    return volume


def half_volume(beam: BeamParameters) -> float:
    """Volume of one half, holes included, m^3."""
    return solid_half_volume(beam) - len(beam.bolt_x) * hole_area(beam) * beam.lap_thickness


def beam_mass(beam: BeamParameters) -> float:
    """Mass of both halves (bolts excluded), kg."""
    return 2 * half_volume(beam) * beam.density


def patch_areas(beam: BeamParameters) -> np.ndarray:
    """Area of each interface patch, m^2, shape (n_patches,): strip area minus the holes it contains."""
    areas = []
    for lower, upper in beam.patch_bounds:
        holes = sum(lower < x < upper for x in beam.bolt_x)
        areas.append((upper - lower) * beam.width - holes * hole_area(beam))
    return np.array(areas)


def patch_second_moments(beam: BeamParameters) -> np.ndarray:
    """Second moments of area of each interface patch about its centroid, m^4, shape (n_patches, 2, 2): the
    matrix J of ``face_second_moments`` for the strip less the circular holes it contains (centred on y = 0).

    Strip of length L (x) and width w (y) centred at x_s: int y^2 dA = L w^3 / 12, int (x - c)^2 dA =
    w L^3 / 12 + L w (x_s - c)^2; a hole of diameter d at x_h removes pi d^4 / 64 from both and
    pi d^2 / 4 (x_h - c)^2 from the second; c is the centroid of the strip less its holes, and every product
    moment int (x - c) y dA vanishes by the mirror symmetry about y = 0.
    """
    moments = []
    for lower, upper in beam.patch_bounds:
        holes = np.array([x for x in beam.bolt_x if lower < x < upper])
        length, centre = upper - lower, (upper + lower) / 2
        strip, hole = length * beam.width, hole_area(beam)
        centroid = (strip * centre - hole * holes.sum()) / (strip - hole * len(holes))
        hole_own = math.pi * beam.hole_diameter ** 4 / 64
        about_x = length * beam.width ** 3 / 12 - len(holes) * hole_own
        about_y = (beam.width * length ** 3 / 12 + strip * (centre - centroid) ** 2
                   - np.sum(hole_own + hole * (holes - centroid) ** 2))
        moments.append(np.diag([about_x, about_y]))
    return np.array(moments)


def face_second_moments(points: np.ndarray, triangles: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Second moments of area of a flat face in a plane z = const about the point ``centre`` (3,), m^4, (2, 2):

        J = int [[y^2, -x y], [-x y, x^2]] dA,   (x, y) measured from the centre,

    so that a rotation (theta_x, theta_y) of the face moves it normally by w = theta_x y - theta_y x and
    int w^2 dA = theta^T J theta. triangles: (m, 3 or 6), corners first; the edge-midpoint rule (A / 3 at each
    mid-side) integrates these quadratics exactly on straight-sided triangles.
    """
    a, b, c = (points[triangles[:, i]] for i in range(3))
    area = triangle_areas(points, triangles)
    moments = np.zeros((2, 2))
    for midpoint in ((a + b) / 2, (b + c) / 2, (c + a) / 2):
        x, y = (midpoint[:, :2] - np.asarray(centre)[:2]).T
        moments += np.array([[area @ (y * y), -area @ (x * y)], [-area @ (x * y), area @ (x * x)]]) / 3
    return moments


def tetrahedron_volumes(points: np.ndarray, tetrahedra: np.ndarray) -> np.ndarray:
    """Volumes of straight-sided tetrahedra, m^3, shape (n,). tetrahedra: (n, 4 or 10), corners first."""
    a, b, c, d = (points[tetrahedra[:, i]] for i in range(4))
    return np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)) / 6


def triangle_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Areas of straight-sided triangles, m^2, shape (n,). triangles: (n, 3 or 6), corners first."""
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return np.linalg.norm(np.cross(b - a, c - a), axis=1) / 2


def hole_volume(points: np.ndarray, wall_triangles: np.ndarray, axis_x: float) -> float:
    """Volume of the polyhedral hole bounded by a meshed hole wall, m^3.

    Divergence theorem with the field (x - axis_x, 0, 0): the flat end caps have n_x = 0 and drop out, so the
    volume is |sum over wall triangles of (centroid_x - axis_x) n_x area|.
    """
    a, b, c = (points[wall_triangles[:, i]] for i in range(3))
    area_normals = np.cross(b - a, c - a) / 2
    centroid_x = (a[:, 0] + b[:, 0] + c[:, 0]) / 3
    return abs(np.sum((centroid_x - axis_x) * area_normals[:, 0]))


def hole_polygon_area(points: np.ndarray, face_nodes: np.ndarray, centre: tuple[float, float],
                      radius: float) -> float:
    """Area of the polygon through the face nodes lying on a hole's circle, m^2 (shoelace formula).

    face_nodes: node indices of a planar face; centre: (x, y) of the hole axis, m; radius: hole radius, m.
    """
    relative = points[face_nodes, :2] - np.asarray(centre)
    on_circle = np.abs(np.hypot(relative[:, 0], relative[:, 1]) - radius) < 1e-9 * max(1.0, radius)
    ring = relative[on_circle]
    ring = ring[np.argsort(np.arctan2(ring[:, 1], ring[:, 0]))]
    x, y = ring[:, 0], ring[:, 1]
    return abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2
