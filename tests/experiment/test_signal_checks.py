"""The signal checks beside the backbone, on virtual hammer hits with known content (``discrepancy.virtual_data``):

- a second mode 3 % above the target with 20 % of its amplitude, of a shape the modal filter projects out of the
  backbone: found at its frequency (within 0.5 %) and amplitude (within 20 %); at 5 % found there or not at all;
- a drift of the frequency by 1e-3 over the hits, either way: found with its sign and its rate (within 10 %);
- clean hits, with or without an amplitude-dependent effect in the backbone: no finding (three seeds);
- clipping, a record that starts in motion, a record that ends before the decay: each found, and only it;
- the findings travel in the backbone CSV and are read back; a malformed findings line is refused.
"""

from dataclasses import replace

import numpy as np
import pytest

from discrepancy.virtual_data import REFERENCE_FREQUENCY_HZ, undeclared_ringdown
from experiment.backbone import mode_backbone, ringdown_backbone
from experiment.backbone_files import read_backbone, write_backbone
from experiment.signal_checks import FINDINGS, record_findings, ringdown_findings

MODE_HZ = 169.0
BAND = (0.7 * MODE_HZ, 1.3 * MODE_HZ)
ORTHOGONAL = ((1.0, 1.0), (1.0, -1.0))  # target and second mode at two sensors: the modal filter separates them
HITS = {"hits": 5, "pretrigger_s": 0.05}


def findings_of(hits):
    """The checks on hits as ``surrogacy freevib`` runs them: backbone first, then its signals."""
    return ringdown_findings(hits, ringdown_backbone(hits, MODE_HZ), BAND)


def named(findings, name):
    return [entry for entry in findings["found"] if entry["name"] == name]


def test_second_mode_at_three_percent_and_a_fifth_is_found_with_its_frequency_and_amplitude():
    findings = findings_of(undeclared_ringdown(second_mode=(1.03, 0.2), shapes=ORTHOGONAL, **HITS))
    assert [entry["name"] for entry in findings["found"]] == ["second_mode"]
    evidence = findings["found"][0]["evidence"]
    true_hz = 1.03 * REFERENCE_FREQUENCY_HZ  # the generator's second mode: 1.03 times the low-amplitude frequency
    assert abs(evidence["frequency_hz"] / true_hz - 1) < 5e-3
    assert abs(evidence["relative_amplitude"] / 0.2 - 1) < 0.2
    assert evidence["channels_checked"] == 10 and findings["found"][0]["outside_library"]


def test_second_mode_at_five_percent_is_found_there_or_not_at_all():
    findings = findings_of(undeclared_ringdown(second_mode=(1.03, 0.05), shapes=ORTHOGONAL, **HITS))
    assert {entry["name"] for entry in findings["found"]} <= {"second_mode"}
    for entry in findings["found"]:
        assert abs(entry["evidence"]["frequency_hz"] / (1.03 * REFERENCE_FREQUENCY_HZ) - 1) < 5e-3


@pytest.mark.parametrize("drift", [1e-3, -1e-3])
def test_frequency_drift_over_the_hits_is_found_with_its_sign_and_rate(drift):
    findings = findings_of(undeclared_ringdown(drift=drift, **HITS))
    assert [entry["name"] for entry in findings["found"]] == ["drift"]
    evidence = findings["found"][0]["evidence"]
    assert evidence["quantity"] == "natural_frequency_hz" and evidence["clock"] == "time stamps of the hits"
    assert evidence["span_s"] == pytest.approx(5 * 4.0, rel=1e-3)  # five hits of 4 s back to back
    assert np.sign(evidence["relative_change_over_span"]) == np.sign(drift)
    assert abs(evidence["relative_change_over_span"] / drift - 1) < 0.1


def test_drift_without_time_stamps_runs_on_the_order_of_the_hits():
    """Hits that all start at t = 0 (a .mat struct with one time vector): the clock is their order, the rate per
    hit, the change over the hits' span the same 1e-3 to within 10 % (each hit starts 4 s after the last)."""
    hits = [replace(hit, time=hit.time - hit.time[0]) for hit in undeclared_ringdown(drift=1e-3, **HITS)]
    findings = findings_of(hits)
    assert [entry["name"] for entry in findings["found"]] == ["drift"]
    evidence = findings["found"][0]["evidence"]
    assert evidence["clock"] == "order of the hits" and evidence["span_hit"] == 4
    assert abs(evidence["relative_change_over_span"] / (1e-3 * 4 / 5) - 1) < 0.1  # 4 of the 5 hit intervals


@pytest.mark.parametrize("seed, effects", [(0, ()), (1, ()), (2, ("microslip",))])
def test_clean_hits_give_no_finding(seed, effects):
    """Effects that live in the backbone (microslip here) are the loop's, not the signal checks'."""
    findings = findings_of(undeclared_ringdown(effects, seed=seed, **HITS))
    assert findings["found"] == [] and set(findings["checked"]) == set(FINDINGS)


def test_record_checks_name_clipping_a_missing_pretrigger_and_a_truncated_record():
    clean = undeclared_ringdown(pretrigger_s=0.05)
    assert record_findings(clean, MODE_HZ, BAND) == []
    signals = clean[0].signals
    clipped = [replace(clean[0], signals=np.clip(signals, -0.7 * np.max(signals), 0.7 * np.max(signals)))]
    late = undeclared_ringdown(pretrigger_s=0.0)
    short = undeclared_ringdown(pretrigger_s=0.05, duration_s=1.5)
    for hits, name in ((clipped, "clipping"), (late, "no_pretrigger"), (short, "truncated_record")):
        assert [entry["name"] for entry in record_findings(hits, MODE_HZ, BAND)] == [name]
    end_level = named({"found": record_findings(short, MODE_HZ, BAND)}, "truncated_record")[0]["evidence"]["levels"]
    assert -40 < end_level[0] < -20  # 1.45 s of decay from the top: about 30 dB down, 30 dB above the noise


def test_findings_travel_in_the_backbone_file(tmp_path):
    hits = undeclared_ringdown(second_mode=(1.03, 0.2), shapes=ORTHOGONAL, hits=1, pretrigger_s=0.05)
    measured = ringdown_backbone(hits, MODE_HZ)
    findings = ringdown_findings(hits, measured, BAND)
    path = tmp_path / "backbone.csv"
    write_backbone(mode_backbone(measured, "virtual beam", "virtual", {"mode_hz": MODE_HZ}, findings), path)
    assert read_backbone(path).findings == findings and "drift" not in findings["checked"]  # one hit
    text = path.read_text().replace('"found": [', '"found": [{"name": "second_mode"}, ')
    path.write_text(text)
    with pytest.raises(ValueError, match=f"{path}: field 'findings'"):
        read_backbone(path)
