"""Stress stiffness K_sigma: Euler buckling of a clamped-free bar and the stress of a linear displacement field."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import scipy.sparse.linalg as spla
from skfem import MeshTet

from fem.elasticity import Material, quadratic_node_coordinates, stiffness_matrix
from fem.modes import node_dofs
from fem.solver import factorize
from fem.stress_stiffness import prestress_from_displacement, stress_stiffness_matrix, uniform_prestress

SECTION = 0.0254  # m
LENGTH = 20 * SECTION


def bar_mesh() -> MeshTet:
    section = np.linspace(0.0, SECTION, 3)
    return MeshTet.init_tensor(np.linspace(0.0, LENGTH, 41), section, section)


def axial_stress(force: float) -> np.ndarray:
    stress = np.zeros((3, 3))
    stress[0, 0] = force / SECTION ** 2
    return stress


def test_clamped_free_bar_buckles_at_the_euler_load_with_shear_correction():
    """P_cr = pi^2 E I / (4 L^2) (n = 1) and 9 times that (n = 2), lowered by shear, P / (1 + P / (kappa G A))
    (0.16 % and 1.4 %). The clamp that also holds the end section's Poisson contraction and a 2 x 2 section
    mesh leave a few 1e-3: the design document's 0.5 % bound (docs/design.md section 3)."""
    material, mesh = Material(), bar_mesh()
    stiffness = stiffness_matrix(mesh, material)
    geometric = stress_stiffness_matrix(mesh, uniform_prestress(axial_stress(-1.0)))  # 1 N compression
    clamped = node_dofs(np.flatnonzero(quadratic_node_coordinates(mesh)[:, 0] < 1e-12)).ravel()
    free = np.setdiff1d(np.arange(stiffness.shape[0]), clamped)
    k, g = stiffness[free][:, free].tocsc(), -geometric[free][:, free]
    # K phi = P (-K_sigma) phi; the largest mu = 1 / P of -K_sigma phi = mu K phi are the lowest loads.
    inverse = spla.LinearOperator(k.shape, matvec=factorize(k), dtype=float)
    mu = spla.eigsh(g, k=4, M=k, Minv=inverse, which="LA", return_eigenvectors=False)
    critical = np.sort(1 / mu)
    youngs, nu = material.youngs_modulus, material.poissons_ratio
    shear_stiffness = 10 * (1 + nu) / (12 + 11 * nu) * youngs / (2 * (1 + nu)) * SECTION ** 2
    euler = np.pi ** 2 * youngs * SECTION ** 4 / 12 / (4 * LENGTH ** 2) * np.array([1, 1, 9, 9])
    np.testing.assert_allclose(critical, euler / (1 + euler / shear_stiffness), rtol=5e-3)


def test_linear_displacement_gives_hookes_uniform_stress_and_the_same_stress_stiffness():
    material, mesh = Material(), bar_mesh()
    coordinates = quadratic_node_coordinates(mesh)
    strain = 1e-4
    displacement = np.zeros_like(coordinates)
    displacement[:, 0] = strain * coordinates[:, 0]  # uniaxial strain: sigma_xx = (lambda + 2 mu) eps
    youngs, nu = material.youngs_modulus, material.poissons_ratio
    lame_lambda = youngs * nu / ((1 + nu) * (1 - 2 * nu))
    expected = np.diag([lame_lambda + youngs / (1 + nu), lame_lambda, lame_lambda]) * strain
    from_field = stress_stiffness_matrix(mesh, prestress_from_displacement(displacement.ravel(), material))
    from_tensor = stress_stiffness_matrix(mesh, uniform_prestress(expected))
    assert abs(from_field - from_tensor).max() < 1e-9 * abs(from_tensor).max()
    assert abs(from_field - from_field.T).max() < 1e-12 * abs(from_field).max()
