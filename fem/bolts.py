"""Bolts: an elastic shank joined to the washer footprints by distributing (RBE3-like) couplings (docs/design.md
section 3).

Each washer footprint has a reference point on the bolt axis. Its six DOFs (translation t, rotation theta) are
the area-weighted least-squares rigid motion of the footprint nodes, minimising
sum_i w_i |u_i - t - theta x (x_i - c)|^2: a distributing coupling that averages and does not stiffen the
footprint. A force F at the reference point reaches the nodes as R^T F (virtual work), i.e. as the consistent
nodal forces of a uniform traction for a pure axial force.

The shank is a two-node Timoshenko beam along z between the lower (z = -H/2) and upper (z = +H/2) reference
points. Its bending and shear stiffness restrain sliding of one half on the other; its axial stiffness
E A / L is left out of the preload step, in which the pretension acts as a force pair (an ABAQUS-style
pretension section: the shank carries exactly the preload), and is present in the dynamic model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import MeshTet

from .coupling import coupling_matrix, nodal_areas
from .elasticity import edge_indices, quadratic_node_coordinates
from .modes import node_dofs


BOLT_PRELOAD = 11580.0  # N per bolt at 20 N m (paper section 4.1), the beams' and the ASB's


@dataclass(frozen=True)
class Bolt:
    """One bolt: shank area m^2, length in tension m, Young's modulus Pa, Poisson's ratio, preload N, and the
    mass kg of bolt, nut and washers (kept half at each footprint).

    Validated like ``fem.elasticity.Material``: area, length and preload finite and positive, E in [1e6, 1e13] Pa,
    nu in [0, 0.5), mass finite and >= 0; a value outside is refused naming the field, before it reaches the
    contact solve (a NaN or negative preload or area ended there in CHOLMOD's "not positive definite").
    """

    area: float = 49.5e-6
    length: float = 0.0254
    youngs_modulus: float = 190e9
    poissons_ratio: float = 0.29
    preload: float = BOLT_PRELOAD
    mass: float = 0.02864

    def __post_init__(self):
        for field, unit in (("area", "m^2"), ("length", "m"), ("preload", "N")):
            value = getattr(self, field)
            if not 0.0 < value < np.inf:
                raise ValueError(f"field '{field}' = {value!r}: expected a finite value > 0 {unit}")
        if not 1e6 <= self.youngs_modulus <= 1e13:
            raise ValueError(f"field 'youngs_modulus' = {self.youngs_modulus!r}: expected 1e+06 to 1e+13 Pa")
        if not 0.0 <= self.poissons_ratio < 0.5:
            raise ValueError(f"field 'poissons_ratio' = {self.poissons_ratio!r}: expected 0 <= nu < 0.5")
        if not 0.0 <= self.mass < np.inf:
            raise ValueError(f"field 'mass' = {self.mass!r}: expected a finite value >= 0 kg")

    @property
    def axial_stiffness(self) -> float:
        """E A / L, N/m."""
        return self.youngs_modulus * self.area / self.length


def quadratic_triangles(mesh: MeshTet, triangles: np.ndarray) -> np.ndarray:
    """Six-node triangles (corners, then mid-sides 01, 12, 20) in the quadratic node numbering of ``mesh``.

    triangles: (n, >=3) vertex indices of a face of the tetrahedral mesh (corners first).
    """
    corners = triangles[:, :3]
    edges = np.stack([edge_indices(mesh, corners[:, a], corners[:, b]) for a, b in ((0, 1), (1, 2), (2, 0))], axis=1)
    if np.any(edges < 0):
        raise ValueError("footprint triangle edge not found in the tetrahedral mesh")
    return np.hstack([corners, mesh.p.shape[1] + edges])


def washer_couplings(mesh: MeshTet, beam_mesh, beam) -> list[tuple[sp.csr_matrix, sp.csr_matrix]]:
    """(lower, upper) couplings of every bolt, reference points on the bolt axes (x = bolt_x, y = 0) at the
    outer lap faces z = -H/2 and +H/2.

    beam_mesh: ``geometry.beam_mesh.BeamMesh`` (faces ``{side}_washer_{b}`` numbered with increasing x);
    beam: ``geometry.parameters.BeamParameters``.
    """
    coordinates = quadratic_node_coordinates(mesh)
    n_dof = 3 * len(coordinates)

    def coupling(side: str, number: int, x: float, z: float) -> sp.csr_matrix:
        triangles = quadratic_triangles(mesh, beam_mesh.faces[f"{side}_washer_{number}"])
        weights = nodal_areas(coordinates, triangles)
        nodes = np.flatnonzero(weights)
        _, matrix = coupling_matrix(coordinates, [(nodes, weights[nodes])], node_dofs(np.arange(len(coordinates))),
                                    n_dof, references=np.array([[x, 0.0, z]]), names=[f"{side}_washer_{number}"])
        return matrix

    return [(coupling("lower", b, x, -beam.height / 2), coupling("upper", b, x, beam.height / 2))
            for b, x in enumerate(beam.bolt_x, start=1)]


def shank_stiffness(bolt: Bolt, axial: bool = True) -> np.ndarray:
    """Two-node Timoshenko beam along +z, (12, 12) N/m, N/rad, DOFs (ux, uy, uz, rx, ry, rz) lower then upper.

    Solid circular shank of the bolt's area; shear coefficient 6 (1 + nu) / (7 + 6 nu). ``axial=False`` leaves out
    E A / L (the preload step, where the pretension is a force pair).
    """
    length, youngs = bolt.length, bolt.youngs_modulus
    shear_modulus = youngs / (2 * (1 + bolt.poissons_ratio))
    second_moment = bolt.area ** 2 / (4 * np.pi)  # pi d^4 / 64 with A = pi d^2 / 4
    shear_coefficient = 6 * (1 + bolt.poissons_ratio) / (7 + 6 * bolt.poissons_ratio)
    phi = 12 * youngs * second_moment / (shear_coefficient * shear_modulus * bolt.area * length ** 2)
    bending = youngs * second_moment / ((1 + phi) * length ** 3) * np.array([
        [12, 6 * length, -12, 6 * length],
        [6 * length, (4 + phi) * length ** 2, -6 * length, (2 - phi) * length ** 2],
        [-12, -6 * length, 12, -6 * length],
        [6 * length, (2 - phi) * length ** 2, -6 * length, (4 + phi) * length ** 2]])
    stiffness = np.zeros((12, 12))
    # Deflection u_x has slope +r_y along z; deflection u_y has slope -r_x.
    for deflection, rotation, sign in ((0, 4, 1.0), (1, 3, -1.0)):
        dofs = np.array([deflection, rotation, 6 + deflection, 6 + rotation])
        signs = np.array([1.0, sign, 1.0, sign])
        stiffness[np.ix_(dofs, dofs)] += bending * np.outer(signs, signs)
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    stiffness[np.ix_([5, 11], [5, 11])] += shear_modulus * 2 * second_moment / length * bar  # torsion, J = 2 I
    if axial:
        stiffness[np.ix_([2, 8], [2, 8])] += bolt.axial_stiffness * bar
    return stiffness


def shank_stress_stiffness(tension: float, length: float) -> np.ndarray:
    """Stress stiffness of a shank along +z carrying the axial force ``tension`` N over ``length`` m, (12, 12) N/m,
    DOFs as ``shank_stiffness``: a taut string, (N / L) [[I, -I], [-I, I]] on the lateral translations x, y.

    A rigid rotation theta normal to the axis moves the ends apart laterally by theta L and stores N L theta^2:
    this balances the solid's stress stiffness under the clamping pair (see ``fem.prestress``).
    """
    string = tension / length * np.array([[1.0, -1.0], [-1.0, 1.0]])
    stiffness = np.zeros((12, 12))
    for lateral in (0, 1):
        stiffness[np.ix_([lateral, 6 + lateral], [lateral, 6 + lateral])] = string
    return stiffness


def assemble_shanks(couplings: list[tuple[sp.csr_matrix, sp.csr_matrix]], shank: np.ndarray) -> sp.csr_matrix:
    """Sum over bolts of R^T k_shank R with R = [R_lower; R_upper] (12, n_dof); shank: (12, 12) element matrix."""
    return sum((lambda r: (r.T @ sp.csr_matrix(shank) @ r))(sp.vstack([lower, upper]).tocsr())
               for lower, upper in couplings).tocsr()


def bolts_stiffness(couplings: list[tuple[sp.csr_matrix, sp.csr_matrix]], bolt: Bolt,
                    axial: bool = True) -> sp.csr_matrix:
    """Elastic stiffness of the bolt shanks (``shank_stiffness``) on their washer couplings, (n_dof, n_dof) N/m."""
    return assemble_shanks(couplings, shank_stiffness(bolt, axial))


def preload_forces(couplings: list[tuple[sp.csr_matrix, sp.csr_matrix]], bolt: Bolt) -> np.ndarray:
    """Nodal forces (n_dof,) N of the pretension: +P e_z on each lower footprint, -P e_z on each upper one.

    Self-equilibrated: they sum to zero force and moment.
    """
    axial = np.zeros(6)
    axial[2] = bolt.preload
    return sum(lower.T @ axial - upper.T @ axial for lower, upper in couplings)


def bolts_mass(couplings: list[tuple[sp.csr_matrix, sp.csr_matrix]], bolt: Bolt) -> sp.csr_matrix:
    """Bolt, nut and washer mass, half at each footprint reference point (translations only), kg."""
    translations = [coupling[:3] for pair in couplings for coupling in pair]
    return sum(0.5 * bolt.mass * (r.T @ r) for r in translations).tocsr()
