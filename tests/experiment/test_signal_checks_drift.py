"""The drift check within each hit (``experiment.signal_checks.drift_findings``), on hits of different strength:

- the project's generator (``discrepancy.virtual_data``), seven hits of 1.7 s from its top amplitude down to half
  of it: a frequency drift of 1e-3 over each hit's decay, either way, with or without time stamps, is found as a
  drift within each hit with its sign and its rate (within 30 %); where the hits' strengths do not follow their
  times, a drift across the hits is named across, not within, and one within is named within alone; clean hits
  give no finding;
- the bin means of a derivative are anticorrelated where bins share an edge (the covariance the fit whitens);
- the drift within each hit taken out of the backbone (``drift_corrected``) gives the backbone of the same hits
  without it, within the correction's own stated error, where the drifted backbone is many of them away;
- the challenge set (``../shared/data/ringdown-challenge``, another generator; skipped where absent): P7, a drift
  within each hit of 1e-3 over 1.65 s, found with its sign and rate (within 30 %); P1, clean, gives none.
"""

import json
from dataclasses import replace

import numpy as np
import pytest

from discrepancy.virtual_data import undeclared_ringdown
from experiment.backbone import mode_backbone, ringdown_backbone
from experiment.measured_files import read_ringdown
from experiment.signal_checks import backbone_times, derivative_covariance, drift_corrected, drift_findings
from locations import CHALLENGE, challenge_ringdown

MODE_HZ = 169.0
GEOMETRIC = 0.5 ** np.linspace(0.0, 1.0, 7)  # hits from the top amplitude down to half of it, in that order
SHUFFLED = GEOMETRIC[[0, 4, 2, 6, 1, 5, 3]]  # the same strengths in an order unrelated to the hits' times
HITS = {"hits": 7, "duration_s": 1.7, "pretrigger_s": 0.05, "start_fractions": GEOMETRIC}
DECAY_S = HITS["duration_s"] - HITS["pretrigger_s"]
WITHIN = "time since each hit's impact"


def drift_of(hits, mode_hz=MODE_HZ):
    return drift_findings(hits, ringdown_backbone(hits, mode_hz))


def unstamped(hits):
    """Hits that all start at t = 0 (no time stamps: the clock across hits is their order)."""
    return [replace(hit, time=hit.time - hit.time[0]) for hit in hits]


@pytest.mark.parametrize("drift, stamped", [(1e-3, True), (-1e-3, False)])
def test_frequency_drift_within_each_hit_is_found_with_its_sign_and_rate(drift, stamped):
    hits = undeclared_ringdown(drift_within_hit=drift, **HITS)
    findings = drift_of(hits if stamped else unstamped(hits))
    assert [entry["evidence"]["clock"] for entry in findings] == [WITHIN]
    evidence = findings[0]["evidence"]
    assert evidence["quantity"] == "natural_frequency_hz" and findings[0]["outside_library"]
    assert np.sign(evidence["relative_rate_per_s"]) == np.sign(drift)
    assert abs(evidence["relative_rate_per_s"] * DECAY_S / drift - 1) < 0.3


@pytest.mark.parametrize("drift, clock", [({"drift": 1e-3}, "time stamps of the hits"),
                                          ({"drift_within_hit": 1e-3}, WITHIN)])
def test_with_strengths_apart_from_times_each_drift_is_named_by_its_own_clock(drift, clock):
    """Both clocks fitted together where the hits' strengths do not follow their times: neither passes for the
    other, and the rate is within 30 % of the truth."""
    findings = drift_of(undeclared_ringdown(**drift, **(HITS | {"start_fractions": SHUFFLED})))
    assert [entry["evidence"]["clock"] for entry in findings] == [clock]
    evidence = findings[0]["evidence"]
    assert "confounded_with" not in evidence
    change = evidence["relative_change_over_span"] if clock != WITHIN else evidence["relative_rate_per_s"] * DECAY_S
    assert abs(change / 1e-3 - 1) < 0.3


@pytest.mark.parametrize("seed, stamped, strengths", [(0, True, GEOMETRIC), (1, False, SHUFFLED)])
def test_clean_hits_of_different_strength_give_no_drift(seed, stamped, strengths):
    hits = undeclared_ringdown(seed=seed, **(HITS | {"start_fractions": strengths}))
    assert drift_of(hits if stamped else unstamped(hits)) == []


def test_the_drift_taken_out_of_the_backbone_gives_the_backbone_without_it():
    """The same seven hits (the same noise) with a frequency drift of -2e-3 over each hit's decay and without it:
    the drifted backbone less r t(a) (the finding's rate r, t(a) the mean time since impact behind each point) is
    the undrifted backbone within three of the error the corrected points state (their own standard error with the
    rate's times t(a): the noise is the same in both, but the two grids, and so the bins' samples, differ by a few
    per mille), while the drifted backbone lies ten or more of them away; the times behind the points rise as the
    amplitude falls, to about the decay's length."""
    clean = ringdown_backbone(undeclared_ringdown(**HITS), MODE_HZ)
    hits = undeclared_ringdown(drift_within_hit=-2e-3, **HITS)
    drifted = ringdown_backbone(hits, MODE_HZ)
    findings = drift_findings(hits, drifted)
    corrected, corrections = drift_corrected(mode_backbone(drifted, "virtual", "virtual", findings={"found": findings}))
    assert list(corrections) == ["natural_frequency_hz"]
    times = backbone_times(drifted, drifted.hilbert.amplitude)
    assert np.all(np.diff(times[np.isfinite(times)]) < 0) and 1.0 < np.nanmax(times) < DECAY_S
    amplitude = corrected.backbone.amplitude
    truth = np.interp(np.log(amplitude), np.log(clean.hilbert.amplitude), clean.hilbert.natural_frequency_hz)
    error = corrected.backbone.natural_frequency_standard_error_hz  # the points' own and the rate's times t(a)
    inside = (amplitude > clean.hilbert.amplitude[0]) & (amplitude < clean.hilbert.amplitude[-1])
    assert np.all(np.abs(corrected.backbone.natural_frequency_hz - truth)[inside] < 3 * error[inside])
    before = np.interp(np.log(amplitude), np.log(drifted.hilbert.amplitude), drifted.hilbert.natural_frequency_hz)
    assert np.max(np.abs(before - truth)[inside] / error[inside]) > 10


def test_bin_means_of_a_derivative_are_anticorrelated_where_bins_share_an_edge():
    """Three bins in a row, two alone: the middle one shares an edge with each neighbour, the last none."""
    edges = np.geomspace(1.0, 32.0, 6)
    covariance = derivative_covariance(np.array([0, 1, 2, 4]), np.array([0.1, 0.2, 0.1, 0.3]), edges)
    correlation = covariance / np.sqrt(np.outer(np.diag(covariance), np.diag(covariance)))
    assert correlation[0, 1] < 0 and correlation[1, 2] < 0
    assert correlation[0, 2] == 0 and np.all(correlation[3, :3] == 0)
    assert covariance[0, 0] == pytest.approx((1 / edges[0] ** 2 + 1 / edges[1] ** 2) / 0.1 ** 2)


def challenge_hits(name, directory):
    """The hits of challenge file ``name``; the test skips where the set is absent."""
    return read_ringdown(challenge_ringdown(name, directory))


def test_challenge_drift_within_each_hit_is_found_with_its_sign_and_rate(tmp_path):
    """P7: omega (1 - drift t / T), t since each hit, T = 1.65 s (the key); no time stamps in the file."""
    findings = drift_of(challenge_hits("P7", tmp_path), 170.0)
    truth = json.loads((CHALLENGE / "key.json").read_text())["cases"]["P7"]["parameters"]["drift"]
    assert [entry["evidence"]["clock"] for entry in findings] == [WITHIN]
    evidence = findings[0]["evidence"]
    assert evidence["quantity"] == "natural_frequency_hz" and evidence["relative_rate_per_s"] < 0
    assert abs(-evidence["relative_rate_per_s"] * 1.65 / truth - 1) < 0.3


def test_challenge_clean_file_gives_no_drift(tmp_path):
    assert drift_of(challenge_hits("P1", tmp_path), 170.0) == []
