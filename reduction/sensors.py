"""Sensor points of the beams and the recovery of displacements at arbitrary points of the mesh (docs/design.md
section 4).

Accelerometers (paper Fig. 2: ten accelerometers along the beam, read normal to the top face). No drawing with
their exact positions is public; we place five on the top face of each body (outside the lap, which carries the
washers and nuts), y = 0, at the fractions 0.1, 0.3, 0.5, 0.7, 0.9 of the body length measured from the lap end,
numbered with increasing x, each reading the z displacement (the out-of-plane bending direction of the first
mode). Where a point falls on the SBRB's flexure the top face there is the flexure's (z = spring_height / 2).

Recovery: the displacement at a point inside an element is the quadratic tetrahedron's interpolation of its ten
nodes' displacements (scikit-fem's ``probes`` on the scalar quadratic basis, whose DOF p is quadratic node p,
applied to each component), so a sensor row is exact for every field the finite element space represents.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import CellBasis, ElementTetP2, MeshTet

from geometry.parameters import BeamParameters

BODY_FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
SENSOR_DIRECTION = 2  # accelerometers read u_z
INSIDE = 1e-9  # m: points are placed this far inside the top face so that exactly one element holds them


def top_face_height(beam: BeamParameters, x: np.ndarray) -> np.ndarray:
    """z of the beam's top face at positions x (n,) m along the bodies: H/2, or spring_height/2 on a flexure."""
    along_body = np.abs(x) - beam.lap_length / 2
    on_flexure = np.abs(along_body - beam.spring_offset) < beam.spring_length / 2
    if beam.spring_height is None:
        return np.full(len(x), beam.height / 2)
    return np.where(on_flexure, beam.spring_height / 2, beam.height / 2)


def accelerometer_points(beam: BeamParameters, body_fractions: tuple[float, ...] = BODY_FRACTIONS) -> np.ndarray:
    """The accelerometer positions (2 n, 3) m on the top face (module docstring), increasing x: n per body at
    ``body_fractions`` (n,) of the body length from the lap end."""
    along_body = beam.lap_length / 2 + beam.body_length * np.asarray(body_fractions)
    x = np.concatenate([-along_body[::-1], along_body])
    return np.column_stack([x, np.zeros(len(x)), top_face_height(beam, x) - INSIDE])


def point_recovery(mesh: MeshTet, points: np.ndarray) -> sp.csr_matrix:
    """Interpolation of the quadratic displacement field at points (n, 3) m: (3 n, n_dof), rows 3 i + k give
    component k of point i from the DOFs 3 p + k of the quadratic nodes (``fem.elasticity``). Raises ValueError
    when a point lies outside the mesh."""
    try:
        scalar = CellBasis(mesh, ElementTetP2()).probes(np.asarray(points, dtype=float).T).tocoo()
    except ValueError as error:
        raise ValueError(f"a recovery point lies outside the mesh ({error})") from None
    rows = 3 * scalar.row[:, None] + np.arange(3)
    columns = 3 * scalar.col[:, None] + np.arange(3)
    values = np.repeat(scalar.data[:, None], 3, axis=1)
    return sp.csr_matrix((values.ravel(), (rows.ravel(), columns.ravel())),
                         shape=(3 * scalar.shape[0], 3 * scalar.shape[1]))
