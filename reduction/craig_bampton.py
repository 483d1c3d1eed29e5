"""Hurty/Craig-Bampton superelement of the two unjoined halves, the patch virtual nodes as boundary (docs/design.md
section 4).

Boundary: the 60 virtual-node DOFs u_b = T u of the ten interface patches (paper 4.1), T (60, n_dof) the
area-weighted least-squares rigid motion of each patch about its centroid (``fem.springs.patch_couplings``,
RBE3-like, built explicitly); rows 6 p .. 6 p + 5 are (t_x, t_y, t_z, theta_x, theta_y, theta_z) of virtual node
p, lower patches 1-5 first, then upper patches 1-5. The displacement is u = Psi_c u_b + Phi eta (Craig & Bampton
1968, paper ref. [14]) with

- constraint modes Psi_c (n_dof, 60): the minimum-strain-energy field with one virtual DOF at unit value and the
  others zero, K psi_j + T^T lambda_j = 0, T psi_j = e_j, the constraints enforced exactly (Lagrange multipliers);
- fixed-interface modes Phi (n_dof, 26): the lowest solutions of K phi = omega^2 M phi with T phi = 0 (every
  virtual DOF held at zero), mass-normalised.

Constrained statics of the free-free halves. K is singular (each half has six rigid motions, the columns of R).
A statically determinate (3-2-1) support on each half (``fem.contact.support_321``) leaves K_s positive
definite; for a self-equilibrated load f (R^T f = 0) every free solution is u = F f + R a, F = K_s^-1 extended
by zeros at the twelve supported DOFs. The constrained problem K u = b - T^T lambda, T u = g therefore becomes,
with G = F T^T (n_dof, 60), S = T G and B = T R (60, 12), the dense 72 x 72 saddle-point system

    [ S    B ] [ lambda ]   [ T F b - g ]
    [ B^T  0 ] [   -a   ] = [   R^T b   ],        u = F b - G lambda + R a,

whose second row is the equilibrium of each half. B has full rank because each half's five patches (30
constraints) restrain its six rigid motions. One sparse Cholesky factorisation of K_s (``fem.solver.factorize``)
serves the constraint modes (b = 0, g = I) and the shift-invert operator of the fixed-interface eigenproblem
(g = 0): b -> u is the inverse of K on the null space of T, symmetric positive semi-definite.

Rigid motions are reproduced exactly: for g = T R c the solution is lambda = 0, u = R c, so the reduced model
holds the full model's mass, centre of mass and rotational inertia. In floating point the 60 constraint modes,
each of entries up to about 20 (a unit virtual translation against held neighbours), are solved column by column
to a relative 1e-13, and their combination B c (B = T R) cancels to a rigid field of size 0.3 only to about
1e-12. So the constraint modes are assembled as Psi_c = R B^+ + (Psi_c - R B^+) (I - B B^+), equal in exact
arithmetic; then Psi_c B = R to the round-off of B^+ B (cond(B) is about 1). The saddle-point solves meet
T Psi_c = I and T Phi = 0 to about 1e-11; a final least-norm correction (T^T (T T^T)^-1 times the constraint
residual, of that size and zero on rigid fields) makes them hold to round-off, so that a patch traction reaches
exactly its own virtual node.

Prestress: one basis, built from the unstressed K, serves both K and K_A = K + K_sigma (a Rayleigh-Ritz
projection, ``reduced_matrix``): both reduced stiffnesses then share coordinates, joint map and recovery
matrices. K_sigma moves the bending frequencies by about 1e-5 (``fem.prestress``), so the basis error this adds
is second order in it, far below the reduction error itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem.elasticity import rigid_body_modes
from fem.modes import node_dofs
from fem.solver import factorize, frequencies_hz, sign_convention

from .superelement import DOFS_PER_PATCH

N_FIXED_INTERFACE_MODES = 26  # paper 4.1: 60 boundary + 26 modal DOFs capture the first four bending modes
VIRTUAL_DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


class PatchLayoutError(ValueError):
    """The interface patches cannot form the superelement's boundary (mismatched sides, wrong counts)."""


def boundary_constraints(lower: sp.spmatrix, upper: sp.spmatrix) -> sp.csr_matrix:
    """The boundary map T = [T_lower; T_upper], (60, n_dof), from the patch couplings of each side.

    lower, upper: (6 n_patches, n_dof) virtual-node couplings (``fem.springs.patch_couplings``); patch p of one
    side pairs with patch p of the other. Raises PatchLayoutError when the sides differ in patch count or size.
    """
    if lower.shape[0] % DOFS_PER_PATCH or upper.shape[0] % DOFS_PER_PATCH:
        raise PatchLayoutError(f"patch couplings must have 6 rows per patch; got {lower.shape[0]} lower and "
                               f"{upper.shape[0]} upper rows")
    if lower.shape != upper.shape:
        raise PatchLayoutError(f"{lower.shape[0] // DOFS_PER_PATCH} lower patches ({lower.shape[1]} DOFs) do not pair "
                               f"with {upper.shape[0] // DOFS_PER_PATCH} upper patches ({upper.shape[1]} DOFs): "
                               "every lower patch needs its upper partner")
    return sp.vstack([lower, upper]).tocsr()


def virtual_dof_labels(n_patches: int, n_modes: int) -> list[str]:
    """Names of the reduced coordinates: '{lower|upper}_patch_{p}_{ux..rz}', then 'fixed_interface_mode_{i}'."""
    return ([f"{side}_patch_{p}_{name}" for side in ("lower", "upper") for p in range(1, n_patches + 1)
             for name in VIRTUAL_DOF_NAMES] + [f"fixed_interface_mode_{i}" for i in range(1, n_modes + 1)])


def half_rigid_modes(coordinates: np.ndarray, halves: np.ndarray) -> np.ndarray:
    """Rigid motions of each half separately, (3 n_nodes, 12): columns 0-5 move the lower half (halves == 0), 6-11
    the upper one (halves == 1), the other half at rest; translations x, y, z (m), then rotations about x, y, z
    through the origin (m/rad), as ``fem.elasticity.rigid_body_modes``.

    coordinates: (n_nodes, 3) m; halves: (n_nodes,) 0 or 1.
    """
    modes = np.zeros((3 * len(coordinates), 2 * DOFS_PER_PATCH))
    for half in (0, 1):
        nodes = np.flatnonzero(halves == half)
        modes[node_dofs(nodes).ravel(), DOFS_PER_PATCH * half:DOFS_PER_PATCH * (half + 1)] = rigid_body_modes(
            coordinates[nodes], centre=np.zeros(3))
    return modes


def constrained_solver(stiffness: sp.spmatrix, constraints: sp.spmatrix, rigid_modes: np.ndarray,
                       supported: np.ndarray, method: str | None = None
                       ) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Exact solver of K u = b - T^T lambda, T u = g for free-free bodies (the saddle system of the module docstring).

    stiffness: K (n_dof, n_dof) N/m, singular only on ``rigid_modes`` (n_dof, r); constraints: T (m, n_dof);
    supported: (r,) DOFs of a statically determinate support, which carries no load; method: factorisation
    (``fem.solver.factorize``). Returns solve(b, g) -> u for loads b (n_dof,) or (n_dof, k) N and constraint
    values g (m,) or (m, k); the multipliers lambda are the constraint forces.
    """
    n_dof, n_constraints = stiffness.shape[0], constraints.shape[0]
    free = np.setdiff1d(np.arange(n_dof), supported)
    solve_free = factorize(sp.csr_matrix(stiffness)[free][:, free], method)

    def flexibility(loads: np.ndarray) -> np.ndarray:
        displacement = np.zeros(loads.shape)
        displacement[free] = solve_free(loads[free])
        return displacement

    constraint_flexibility = flexibility(constraints.T.toarray())
    coupled = constraints @ rigid_modes
    schur = constraints @ constraint_flexibility  # kept as computed (not symmetrised): T u = g to round-off
    saddle = np.block([[schur, coupled], [coupled.T, np.zeros((rigid_modes.shape[1],) * 2)]])
    # Symmetric diagonal scaling: virtual translations (m/N) and rotations (rad/(N m)) differ by orders of magnitude.
    multiplier_scaling = 1 / np.sqrt(np.diag(schur))
    scaling = np.concatenate([multiplier_scaling,
                              1 / np.linalg.norm(multiplier_scaling[:, None] * coupled, axis=0)])
    factors = scipy.linalg.lu_factor(scaling[:, None] * saddle * scaling)

    def solve(loads: np.ndarray, values: np.ndarray) -> np.ndarray:
        free_displacement = flexibility(loads)
        right_hand_side = np.concatenate([constraints @ free_displacement - values, rigid_modes.T @ loads])
        unknowns = (scaling * scipy.linalg.lu_solve(factors, (scaling * right_hand_side.T).T).T).T
        multipliers, amplitudes = unknowns[:n_constraints], -unknowns[n_constraints:]
        return free_displacement - constraint_flexibility @ multipliers + rigid_modes @ amplitudes

    return solve


def fixed_interface_modes(stiffness: sp.spmatrix, mass: sp.spmatrix,
                          solve: Callable[[np.ndarray, np.ndarray], np.ndarray], constraints: sp.spmatrix,
                          n_modes: int = N_FIXED_INTERFACE_MODES) -> tuple[np.ndarray, np.ndarray]:
    """Lowest modes of K phi = omega^2 M phi with T phi = 0, by shift-invert Lanczos about 0 with the constrained
    inverse of K (``constrained_solver`` with g = 0) as the operator.

    The Lanczos vectors satisfy T phi = 0 to the saddle-point solve's round-off (1e-11 relative); the modes are
    then projected onto the null space of T (a correction of that size), so that a patch load reaches no modal
    coordinate beyond 1e-16. Returns (frequencies (n_modes,) Hz ascending, shapes (n_dof, n_modes) mass-normalised,
    sign fixed so that the largest entry is positive, for reproducible files).
    """
    n_dof = stiffness.shape[0]
    held = np.zeros(constraints.shape[0])
    inverse = spla.LinearOperator((n_dof, n_dof), matvec=lambda b: solve(b, held), dtype=float)
    eigenvalues, shapes = spla.eigsh(stiffness, k=n_modes, M=mass, sigma=0.0, OPinv=inverse, which="LM",
                                     v0=np.ones(n_dof))
    order = np.argsort(eigenvalues)
    shapes = shapes[:, order]
    shapes -= constraints.T @ np.linalg.solve((constraints @ constraints.T).toarray(), constraints @ shapes)
    shapes /= np.sqrt(np.einsum("ij,ij->j", shapes, mass @ shapes))
    return frequencies_hz(eigenvalues[order]), sign_convention(shapes)


def reduced_matrix(matrix: sp.spmatrix, basis: np.ndarray) -> np.ndarray:
    """Rayleigh-Ritz projection Psi^T A Psi, (n_reduced, n_reduced), symmetrised; units of A."""
    projected = basis.T @ (matrix @ basis)
    return 0.5 * (projected + projected.T)


@dataclass(frozen=True)
class HurtyCraigBampton:
    """The Hurty/Craig-Bampton reduction u = basis @ q, q = (u_b (n_boundary), eta (n_modes)).

    basis: (n_dof, n_boundary + n_modes), constraint modes (m per unit virtual DOF: m/m, m/rad) then fixed-interface
    modes (mass-normalised, m kg^-1/2); mass: reduced M, kg; stiffness: reduced K, N/m (units per coordinate);
    fixed_interface_frequencies: (n_modes,) Hz.
    """

    basis: np.ndarray
    mass: np.ndarray
    stiffness: np.ndarray
    fixed_interface_frequencies: np.ndarray


def hurty_craig_bampton(stiffness: sp.spmatrix, mass: sp.spmatrix, constraints: sp.spmatrix,
                        rigid_modes: np.ndarray, supported: np.ndarray, n_modes: int = N_FIXED_INTERFACE_MODES,
                        method: str | None = None) -> HurtyCraigBampton:
    """Reduce (K, M) of free-free bodies to the boundary DOFs T u and ``n_modes`` fixed-interface modes.

    stiffness, mass: (n_dof, n_dof), N/m and kg; constraints: T (n_boundary, n_dof); rigid_modes: (n_dof, r)
    the null space of K; supported: (r,) DOFs of a statically determinate support (``constrained_solver``).
    """
    n_boundary = constraints.shape[0]
    solve = constrained_solver(stiffness, constraints, rigid_modes, supported, method)
    rigid_boundary = constraints @ rigid_modes
    rigid_fit = np.linalg.pinv(rigid_boundary)
    rigid_part = rigid_modes @ rigid_fit
    constraint_modes = rigid_part + (solve(np.zeros((stiffness.shape[0], n_boundary)), np.eye(n_boundary))
                                     - rigid_part) @ (np.eye(n_boundary) - rigid_boundary @ rigid_fit)
    constraint_modes += constraints.T @ np.linalg.solve((constraints @ constraints.T).toarray(),
                                                        np.eye(n_boundary) - constraints @ constraint_modes)
    frequencies, modes = fixed_interface_modes(stiffness, mass, solve, constraints, n_modes)
    basis = np.hstack([constraint_modes, modes])
    return HurtyCraigBampton(basis, reduced_matrix(mass, basis), reduced_matrix(stiffness, basis), frequencies)


def relative_patch_motion(n_patches: int, n_reduced: int) -> np.ndarray:
    """The joint map (6 n_patches, n_reduced): upper minus lower virtual-node motion of each patch pair, in the
    coordinates of ``hurty_craig_bampton`` (lower virtual DOFs, upper virtual DOFs, modal)."""
    size = DOFS_PER_PATCH * n_patches
    motion = np.zeros((size, n_reduced))
    motion[:, :size] = -np.eye(size)
    motion[:, size:2 * size] = np.eye(size)
    return motion


def rigid_body_properties(rigid_mass: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass kg, centre of mass (3,) m and rotational inertia about it (3, 3) kg m^2 from the 6 x 6 mass matrix of
    the rigid motions about the origin, R^T M R (translations, then rotations: ``fem.elasticity.rigid_body_modes``).

    Its translation block is m I; its coupling block has entries (i, j) = m (e_j x c)_i, so c_x, c_y, c_z are
    entries (1, 2), (2, 0), (0, 1) over m; its rotation block is the inertia about the origin,
    J_0 = J_c + m (|c|^2 I - c c^T) (parallel axes).
    """
    total = np.trace(rigid_mass[:3, :3]) / 3
    coupling = rigid_mass[:3, 3:] / total
    centre = np.array([coupling[1, 2], coupling[2, 0], coupling[0, 1]])
    parallel_axes = total * (centre @ centre * np.eye(3) - np.outer(centre, centre))
    return total, centre, rigid_mass[3:, 3:] - parallel_axes
