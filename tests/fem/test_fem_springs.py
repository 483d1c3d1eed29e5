"""Modes of the coarse BRB with the lap joined by linear springs between patch virtual nodes (about 30 s)."""

import numpy as np
import pytest

from fem.elasticity import (Material, mass_matrix, quadratic_node_coordinates, rigid_body_modes, solid_mesh,
                            stiffness_matrix)
from fem.modes import interface_quadratic_pairs, tie_transformation, tied_modes
from fem.solver import natural_modes
from fem.springs import joint_stiffness, patch_couplings
from geometry.beam_mesh import interface_partners

ARM = 0.01  # m: rotational springs k_r = k ARM^2, a patch-sized lever on the translational stiffness k


def springs(translational: float, rotational_arm: float = ARM) -> np.ndarray:
    return np.array([translational] * 3 + [translational * rotational_arm ** 2] * 3)


@pytest.fixture(scope="module")
def brb(coarse_brb):
    mesh = solid_mesh(coarse_brb.points, coarse_brb.tetrahedra)
    stiffness, mass = stiffness_matrix(mesh, Material()), mass_matrix(mesh, Material())
    references, lower, upper = patch_couplings(mesh, coarse_brb)
    tie = tie_transformation(stiffness.shape[0], *interface_quadratic_pairs(mesh, *interface_partners(coarse_brb)))
    return mesh, stiffness, mass, references, lower, upper, tie


def rigid_count(frequencies: np.ndarray) -> int:
    """Modes below 1e-4 of the first clearly elastic one (round-off of the shift-invert solve, as in test_fem_modes)."""
    return int(np.count_nonzero(np.abs(frequencies) < 1e-4 * frequencies[-1]))


def test_virtual_nodes_follow_rigid_motions_and_sit_on_the_lap_axis(brb):
    mesh, _, _, references, lower, upper, _ = brb
    rigid = rigid_body_modes(quadratic_node_coordinates(mesh))
    np.testing.assert_allclose((upper - lower) @ rigid, 0.0, atol=1e-12)  # a rigid beam stretches no spring
    np.testing.assert_allclose(references[:, 1:], 0.0, atol=1e-12)


def test_zero_springs_leave_twelve_rigid_modes_translational_seven_all_six(brb):
    """Two free halves: 12. Translational springs only: the patch centroids lie on the x axis, so a relative twist
    of the halves about x moves none of them: 7. With rotational springs: the six of the joined beam."""
    _, stiffness, mass, _, lower, upper, _ = brb
    for spring, expected in ((springs(0.0), 12), (springs(1e9, 0.0), 7), (springs(1e9), 6)):
        frequencies, _ = natural_modes(stiffness + joint_stiffness(lower, upper, spring), mass, expected + 1)
        assert rigid_count(frequencies) == expected
        assert frequencies[expected] > 100.0


def test_stiff_springs_approach_the_tied_bending_frequency_from_below(brb):
    """Raising k raises the first out-of-plane bending frequency monotonically towards a limit below the tied
    value: the virtual nodes average each patch (RBE3-like), so infinitely stiff springs tie only the patches'
    mean rigid motions and the nodes inside a patch may still slide and open against each other. Measured limit
    194.8 Hz against 201.8 Hz tied (3.5 % below): assert within 5 %, and converged (1e12 -> 1e13 N/m below 1e-4)."""
    _, stiffness, mass, _, lower, upper, tie = brb
    tied, _ = tied_modes(stiffness, mass, tie, 7)
    bending = []
    for k in (1e8, 1e10, 1e12, 1e13):
        frequencies, shapes = natural_modes(stiffness + joint_stiffness(lower, upper, springs(k)), mass, 7)
        mode = shapes[:, 6].reshape(-1, 3)
        assert np.linalg.norm(mode[:, 2]) > 10 * np.linalg.norm(mode[:, 1])  # out of plane
        bending.append(frequencies[6])
    assert np.all(np.diff(bending) > 0)
    assert bending[-1] < tied[6]
    assert bending[-1] > 0.95 * tied[6]
    assert bending[-1] / bending[-2] - 1 < 1e-4
