"""Tied modes of the coarse BRB with and without the bolt prestress (about 15 s)."""

import numpy as np
import pytest

from fem.bolts import Bolt
from fem.elasticity import rigid_body_modes
from fem.prestress import prestressed_beam
from geometry.parameters import BEAMS


@pytest.fixture(scope="module")
def brb(coarse_brb):
    return prestressed_beam(coarse_brb, BEAMS["BRB"], n_modes=8)


def test_stress_stiffness_is_symmetric_and_blind_to_rigid_translations(brb):
    geometric = brb.stress_stiffness
    assert abs(geometric - geometric.T).max() < 1e-12 * abs(geometric).max()
    translations = rigid_body_modes(brb.coordinates)[:, :3]
    assert np.abs(geometric @ translations).max() < 1e-9 * abs(geometric).max()


def test_six_rigid_modes_with_and_without_prestress(brb):
    """The shanks' tension balances the solid's clamp stress (fem.prestress), so rigid rotations store no
    energy: six eigenvalues at round-off, frequencies below 1e-4 of the first elastic one (as in test_fem_modes)."""
    for frequencies in (brb.frequencies, brb.prestressed_frequencies):
        assert np.all(np.abs(frequencies[:6]) < 1e-4 * frequencies[6])
        assert frequencies[6] > 100.0


def test_prestress_lowers_the_first_bending_frequency_slightly(brb):
    """The clamp's through-thickness compression softens the lap: the first out-of-plane bending frequency drops,
    by less than the 0.04 % CalculiX found for stuck contact (docs/design.md section 3.1), and by more than the
    eigen-solver's round-off (the rigid modes' 1e-3 Hz on 200 Hz is an eigenvalue error near 1e-11 relative)."""
    change = brb.prestressed_frequencies[6] / brb.frequencies[6] - 1
    assert -4e-4 < change < -1e-7
    tied, prestressed = brb.shapes[:, 6], brb.prestressed_shapes[:, 6]
    assert abs(tied @ brb.mass @ prestressed) > 0.999  # the same mode (mass-normalised MAC)
    bending = tied.reshape(-1, 3)
    assert np.linalg.norm(bending[:, 2]) > 10 * np.linalg.norm(bending[:, 1])


def test_clamp_force_of_the_preload_solution(brb):
    np.testing.assert_allclose(brb.contact.normal_force.sum(), 3 * Bolt().preload, rtol=1e-3)
