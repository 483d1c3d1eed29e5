"""Distributing couplings: the RBE3-like reference node averages a node set's motion without stiffening it.

Checked on the whole-joint interface patches of the BRB mesh, linear and quadratic faces."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.beam_mesh import read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BRB, MeshParameters
from fem.coupling import CouplingError, coupling_matrix, nodal_areas, rigid_average

PATCHES = [f"{side}_patch_{p}" for side in ("lower", "upper") for p in range(1, 6)]


@pytest.fixture(scope="module", params=[1, 2], ids=["linear", "quadratic"])
def mesh(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp(f"order{request.param}")
    sizes = MeshParameters(size=0.0127, lap_size=0.0064, hole_size=0.0032, order=request.param)
    make_beam(BRB, sizes, folder, render=False)
    return read_beam_mesh(folder / "BRB.msh")


def _transformation(mesh):
    patches = []
    for name in PATCHES:
        weights = nodal_areas(mesh.points, mesh.faces[name])
        nodes = mesh.face_nodes(name)
        patches.append((nodes, weights[nodes]))
    nodal_dofs = np.arange(3 * len(mesh.points)).reshape(-1, 3)
    return coupling_matrix(mesh.points, patches, nodal_dofs, 3 * len(mesh.points), names=PATCHES)


def test_nodal_areas_sum_to_the_patch_areas(mesh):
    from geometry.properties import triangle_areas

    for name in PATCHES:
        assert nodal_areas(mesh.points, mesh.faces[name]).sum() == pytest.approx(
            triangle_areas(mesh.points, mesh.faces[name]).sum(), rel=1e-13)


def test_rigid_motion_of_each_half_is_reproduced_exactly(mesh):
    """u = t0 + theta0 x (x - x0) gives every virtual node t = t0 + theta0 x (c - x0), theta = theta0."""
    centroids, transformation = _transformation(mesh)
    rng = np.random.default_rng(7)
    t0, theta0, x0 = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-2, rng.normal(size=3) * 0.1
    displacement = t0 + np.cross(theta0, mesh.points - x0)
    virtual = (transformation @ displacement.ravel()).reshape(-1, 6)
    expected_t = t0 + np.cross(theta0, centroids - x0)
    scale = np.abs(displacement).max()
    assert np.abs(virtual[:, :3] - expected_t).max() < 1e-12 * scale
    assert np.abs(virtual[:, 3:] - theta0).max() < 1e-12 * np.abs(theta0).max()


def test_rigid_motion_about_a_reference_point(mesh):
    """About a reference point a: t = t0 + theta0 x (a - x0), theta = theta0, for every patch."""
    rng = np.random.default_rng(11)
    t0, theta0, x0 = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-2, rng.normal(size=3) * 0.1
    displacement = t0 + np.cross(theta0, mesh.points - x0)
    for name in PATCHES:
        nodes = mesh.face_nodes(name)
        weights = nodal_areas(mesh.points, mesh.faces[name])[nodes]
        reference = rng.normal(size=3) * 0.02
        point, block = rigid_average(mesh.points[nodes], weights, reference, name)
        motion = block @ displacement[nodes].ravel()
        assert np.array_equal(point, reference)
        assert np.abs(motion[:3] - t0 - np.cross(theta0, reference - x0)).max() < 1e-12 * np.abs(displacement).max()
        assert np.abs(motion[3:] - theta0).max() < 1e-12 * np.abs(theta0).max()


def test_centroids_are_the_area_centroids_of_the_patches(mesh):
    """The weighted centroid is the patch's area centroid; faceting of the hole shifts it off the patch
    centre by at most (missing hole area) x (hole radius) / (patch area)."""
    from geometry.properties import hole_area, hole_polygon_area, triangle_areas

    centroids, _ = _transformation(mesh)
    radius = BRB.hole_diameter / 2
    for centroid, name, (lower, upper) in zip(centroids, PATCHES, BRB.patch_bounds * 2):
        triangles = mesh.faces[name]
        areas = triangle_areas(mesh.points, triangles)
        area_centroid = areas @ mesh.points[triangles[:, :3]].mean(axis=1) / areas.sum()
        np.testing.assert_allclose(centroid, area_centroid, atol=1e-12)
        missing = sum(hole_area(BRB) - hole_polygon_area(mesh.points, mesh.face_nodes(name), (x, 0.0), radius)
                      for x in BRB.bolt_x if lower < x < upper)
        bound = missing * radius / areas.sum() + 1e-12
        assert np.abs(centroid - [(lower + upper) / 2, 0.0, 0.0]).max() <= bound


def test_uniform_traction_maps_to_force_and_no_moment(mesh):
    """Virtual work: the virtual-node load of nodal forces f is T_rigid^T f = (resultant, moment about c)."""
    for name in PATCHES:
        nodes = mesh.face_nodes(name)
        weights = nodal_areas(mesh.points, mesh.faces[name])[nodes]
        centroid, block = rigid_average(mesh.points[nodes], weights, name=name)
        traction = np.array([2.0e5, -1.0e5, 3.0e6])  # Pa
        forces = weights[:, None] * traction
        r = mesh.points[nodes] - centroid
        size = np.ptp(mesh.points[nodes], axis=0).max()
        np.testing.assert_allclose(forces.sum(axis=0), traction * weights.sum(), rtol=1e-13)
        assert np.abs(np.cross(r, forces).sum(axis=0)).max() < 1e-12 * np.abs(forces).sum() * size
        # and the virtual node of a translated patch is that translation with no rotation
        translation = np.tile([1e-6, 2e-6, -3e-6], len(nodes))
        np.testing.assert_allclose(block @ translation, [1e-6, 2e-6, -3e-6, 0, 0, 0], atol=1e-12 * 3e-6 / size)


def test_average_does_not_see_deformation_orthogonal_to_rigid_motions(mesh):
    """A nodal field w-orthogonal to all rigid motions (pure deformation) leaves the virtual node at rest."""
    name = "lower_patch_3"
    nodes = mesh.face_nodes(name)
    weights = nodal_areas(mesh.points, mesh.faces[name])[nodes]
    centroid, block = rigid_average(mesh.points[nodes], weights, name=name)
    r = mesh.points[nodes] - centroid
    rigid = np.hstack([np.tile(np.eye(3), (len(nodes), 1)),
                       np.vstack([np.cross(np.eye(3)[k], r).ravel() for k in range(3)]).T])
    field = np.random.default_rng(3).normal(size=3 * len(nodes))
    w = np.repeat(weights, 3)
    coefficients = np.linalg.solve(rigid.T @ (w[:, None] * rigid), rigid.T @ (w * field))
    deformation = field - rigid @ coefficients
    assert np.abs(block @ deformation).max() < 1e-10 * np.abs(block @ field).max()


def test_patch_with_too_few_or_collinear_nodes_is_refused():
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [0.0, 1.0, 0]])
    with pytest.raises(CouplingError, match="needs at least 3"):
        rigid_average(points[:2], np.ones(2), name="patch 1")
    with pytest.raises(CouplingError, match="one line"):
        rigid_average(points[:3], np.ones(3), name="patch 2")
    with pytest.raises(CouplingError, match="patch 3: 2 weighted"):
        rigid_average(points, np.array([1.0, 0.0, 0.0, 1.0]), name="patch 3")
