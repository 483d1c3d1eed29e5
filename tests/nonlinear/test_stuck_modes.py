"""The small exact stuck eigenproblem (``nonlinear.stuck_modes``) against the full eigen-solve.

The full problem is (M, K + B^T K_d B) in the unjoined modal coordinates of ``joint_space`` (a congruence of
the superelement's own, identity mass): the n_modes x n_modes matrix Lambda + Phi^T K_d Phi. A plain
symmetric eigen-solve of it has a backward error of eps times its norm, and its norm is at least the
largest unjoined eigenvalue (7e14 rad^2/s^2 for CD1) even for soft joints: up to 1e-7 of the target
eigenvalue. The reference therefore refines that solution by inverse iteration with the Rayleigh quotient
in the full space, which converges to the same eigenpair with a residual at round-off.
"""

import numpy as np
import pytest

from nonlinear.condensation import (CUTOFF_FACTOR, UNAMBIGUOUS_MAC, joint_space, modal_assurance, modal_split,
                                    stuck_modes, stuck_stiffness_matrix)
from nonlinear.joint import patch_elements, random_designs, stuck_stiffness
from nonlinear.qsma import stuck_target_mode
from nonlinear.stuck_modes import SERIES_TERMS, _high_flexibility, near_modes


def full_target_mode(space, joint_stiffness):
    """Target (largest MAC) eigenpair of the full stuck matrix: the QSMA oracle's dense eigen-solve refined by
    Rayleigh quotient iteration with the energy quotient (``nonlinear.qsma.stuck_target_mode``)."""
    stuck = stuck_target_mode(space, joint_stiffness)
    return stuck.eigenvalue, stuck.shape, stuck.mac


@pytest.mark.parametrize("configuration", ["CD1", "C1"])
def test_small_eigen_solve_equals_the_full_eigen_solve(configuration, asb_superelement):
    """Random Table 3 designs (joint stiffnesses 1e2 to 1e14 N/m): same target eigenvalue within 1e-9, same
    shape (MAC > 0.999999) where the target is unambiguous, and the same MAC against the reference."""
    space = joint_space(asb_superelement(configuration))
    groups = space.superelement.patch_groups
    designs = random_designs("iwan4", 60, max(groups) + 1, np.random.default_rng(21))
    stiffness = stuck_stiffness(patch_elements("iwan4", designs, groups))
    small = stuck_modes(space, stiffness)
    assert small.found.all()
    for design, k in enumerate(stiffness):
        eigenvalue, shape, mac = full_target_mode(space, k)
        if mac < UNAMBIGUOUS_MAC:
            continue
        assert small.eigenvalue[design] == pytest.approx(eigenvalue, rel=1e-9)
        assert (shape @ small.shape[design]) ** 2 > 0.999999
        assert small.mac[design] == pytest.approx(mac, abs=1e-6)


def test_ambiguous_targets_are_the_best_match_among_all_branches(asb_superelement):
    """Where no stuck mode matches the reference with MAC > 0.5 (veering modes, one to three per thousand of
    CD1's Table 3 designs), every branch of the small problem is solved and the best match kept: the same mode
    as the full eigen-solve's largest MAC (a MAC <= 1 / CUTOFF_FACTOR above the cutoff cannot win here)."""
    space = joint_space(asb_superelement("CD1"))
    groups = space.superelement.patch_groups
    designs = random_designs("jenkins", 1500, max(groups) + 1, np.random.default_rng(3))
    stiffness = stuck_stiffness(patch_elements("jenkins", designs, groups))
    shapes = np.linalg.eigh(stuck_stiffness_matrix(space, stiffness))[1]
    ambiguous = np.flatnonzero(modal_assurance(shapes, space.reference).max(axis=1) < UNAMBIGUOUS_MAC)
    assert len(ambiguous) >= 2
    small = stuck_modes(space, stiffness[ambiguous])
    assert small.found.all()
    for design, k in enumerate(stiffness[ambiguous]):
        eigenvalue, shape, mac = full_target_mode(space, k)
        assert mac > 1.0 / CUTOFF_FACTOR
        assert small.eigenvalue[design] == pytest.approx(eigenvalue, rel=1e-9)
        assert small.mac[design] == pytest.approx(mac, abs=1e-6)


@pytest.mark.parametrize("configuration", ["CD1", "C1"])
def test_flexibility_from_the_far_modes_series_equals_the_explicit_sum(configuration, asb_superelement):
    """F(mu) = Phi_E (Lambda_E - mu)^-1 Phi_E^T with the far high modes by their Taylor series in mu equals the
    sum over every high mode in 40-digit arithmetic within 1e-15 of its largest entry, for mu across the range the
    solver visits (|mu| below the lowest high mode, and at and past it where the sum is explicit)."""
    mpmath = pytest.importorskip("mpmath")
    space = joint_space(asb_superelement(configuration))
    split = modal_split(space)
    high_eigenvalues = space.eigenvalues[split.high]
    phi = space.joint_modes[:, split.high]
    assert 0 < near_modes(high_eigenvalues) < high_eigenvalues.size  # both parts of the basis are exercised
    rows, columns = np.tril_indices(phi.shape[0])
    lowest = high_eigenvalues[0]
    weights, coefficients = np.empty(high_eigenvalues.size), np.empty(SERIES_TERMS + high_eigenvalues.size)
    packed = np.empty(rows.size)
    with mpmath.workdps(40):
        for mu in (-0.9 * lowest, 0.0, 1e-3 * lowest, 0.5 * lowest, 0.999 * lowest, 1.5 * lowest):
            _high_flexibility(mu, high_eigenvalues, split.flexibility, weights, coefficients, packed)
            exact = np.array([float(mpmath.fsum(mpmath.mpf(float(phi[i, e])) * mpmath.mpf(float(phi[j, e]))
                                                / (mpmath.mpf(float(high_eigenvalues[e])) - mpmath.mpf(mu))
                                                for e in range(high_eigenvalues.size)))
                              for i, j in zip(rows, columns)])
            assert np.abs(packed - exact).max() <= 1e-15 * np.abs(exact).max()
            np.testing.assert_array_equal(weights, 1.0 / (high_eigenvalues - mu))
