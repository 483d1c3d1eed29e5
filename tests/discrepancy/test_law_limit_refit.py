"""The fit of Iwan's law held at its limit (chi -> 0) on a clean virtual ring-down of an Iwan joint: the law is held
there, and (an expected failure, ONE_PATCH_LAW) the microslip model should reach the noise with nothing added.

The ring-down (virtual, made here, nothing copied): the challenge set's reference backbone (a four-parameter Iwan
joint of three patch groups on the BRB superelement, QSMA; ``../shared/data/ringdown-challenge``, skipped where
absent) in the layout of the challenge README (``benchmarks.second_mode.challenge_like_clean``: ten accelerometers,
seven hits from 2 q_top down to q_top, 6.4 kHz, 0.35 % noise, 1e-3 quantisation), noise seed 42, through FreeVib as
``surrogacy freevib`` runs it, with the reference's own nominal (169.86148 Hz, 1.666e-3). Two of its patch groups
slip, at very different loads; the loop's one Iwan element does not follow both to the backbone's precision. About
15 s.
"""

import pytest

from discrepancy.loop import AT_NOISE, base_starts, discrepancy_loop, fit
from experiment.ringdown_analysis import analyse_ringdown
from locations import CHALLENGE
from study.structures import measured_levels

REFERENCE = CHALLENGE / "reference_backbone.csv"
F0, ZETA0 = 169.86148, 1.666e-3


pytestmark = pytest.mark.skipif(not REFERENCE.is_file(), reason=f"{REFERENCE} not found (the ring-down challenge set)")

ONE_PATCH_LAW = pytest.mark.xfail(strict=False, reason=(
    "the joint behind the file has two slipping patch groups of slip forces 193 N and 6,130 N; with its backbone "
    "points at their grid amplitudes (within their standard errors of the known backbone), one Iwan element "
    "leaves chi^2/dof 1.63 (seed 42) and 1.58 (seed 7), systematic at the upper levels (frequency +1.2 to +2.4, "
    "then -3.1 standard uncertainties), and the loop then names a stiffness change; it reached 1.28 only while the "
    "upper points stood at lower amplitudes' values"))


@pytest.fixture(scope="module")
def clean_iwan():
    """(measurement, microslip fit held at chi's limit) of the clean challenge-like ring-down, noise seed 42."""
    from benchmarks.second_mode import challenge_like_clean, challenge_like_hits, read_backbone_table

    hits = challenge_like_hits(challenge_like_clean(read_backbone_table(REFERENCE)), 42)
    backbone, _ = analyse_ringdown(hits, 170.0, "clean challenge-like", "virtual")
    measurement = measured_levels(backbone)
    return measurement, fit(measurement, ("microslip",), F0, ZETA0, base_starts(measurement, F0))


def test_clean_iwan_ringdown_held_at_the_law_limit(clean_iwan):
    _, microslip = clean_iwan
    assert "chi" in microslip.held  # Iwan's law at its linear limit, as the joint's slipping patches (chi -0.04)


@ONE_PATCH_LAW
def test_clean_iwan_ringdown_held_at_the_law_limit_reaches_the_noise(clean_iwan):
    measurement, microslip = clean_iwan
    n = 2 * measurement.amplitude.size
    assert microslip.chi_squared / (n - microslip.n_parameters) < AT_NOISE
    verdict = discrepancy_loop(measurement, F0, ZETA0)
    assert verdict.effects == ["microslip"] and not verdict.alternatives and not verdict.unexplained
