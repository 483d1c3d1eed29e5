"""The signal checks and the discrepancy loop on ring-downs the project did not make: the challenge set beside the
repository (``../shared/data/ringdown-challenge``: virtual hammer ring-downs of the BRB's first bending mode from
another generator, each with an effect outside the joint, and their key), run as a user runs them,
``surrogacy freevib FILE --mode-hz 170`` then ``surrogacy discrepancy BACKBONE``.

The expected answer comes from the key's parameters, not from the file names: mass -> stiffness_change (omega /
sqrt(m)), added_zeta -> linear_damping, c_per_q -> amplitude_damping (zeta + c q), k_per_q2 -> cubic_stiffening
(omega (1 + k q^2)); each named with its size within 10 % and nothing else outside the joint; the joint's own law
(an Iwan joint) is the joint law, not an effect; no effect: clean, not unexplained; a second mode or a drift
within the hits (outside any backbone library): unexplained, with the finding that names it (the second mode's
frequency within 0.5 % and its share within 30 %; the drift's sign and rate within 30 %, and, the drift taken
out of the backbone, the key's effects outside the joint and nothing else).

Without the nominal options the nominal is estimated from the file's lowest decade with its standard errors
(``discrepancy.nominal``): an offset (mass loading, linear damping) may then be taken into the nominal, which then
holds the key's loaded frequency and added damping within two of its stated standard errors, the verdict saying
that an offset cannot be told from an estimated nominal (``nominal_caveat``); where
two models are as good (BIC within 10) the verdict lists the other beside its answer; the key's other effects are
named in the answer or in a model it lists as as good, and nothing else outside the joint (a mass loading with a
cubic stiffening under an estimated nominal: the cubic stiffening, with amplitude damping listed as as good).

Conversions: FreeVib's amplitude is the sensor that moves most (acc1, x = 0.81209 q, ``x_over_q_at_acc1``); the
loop writes the effects in q / q_max (q_max its largest fitted amplitude): c = c_loop / q_max [per sensor
amplitude], so c_per_q = c x/q; omega^2 + gamma omega_0^2 (q / q_max)^2 is omega (1 + gamma / 2 (q / q_max)^2)
to first order, so k_per_q2 = gamma / 2 (x/q)^2 / q_max^2.
"""

import json

import pytest

from locations import CHALLENGE, challenge_ringdown
from cli.console import main
from discrepancy.effects import EFFECTS

KEY = CHALLENGE / "key.json"
NOMINAL = ("--nominal-frequency-hz", "169.86148", "--nominal-damping", "1.666e-3")
SIZE = 0.1
pytestmark = pytest.mark.skipif(not KEY.is_file(), reason=f"{CHALLENGE} not found (the ring-down challenge set)")


LONGEST = {"P3", "P5", "P8"}
"""The cases whose loop takes about a minute each with the key's nominal (two slip stages and an effect to size):
in ``make test-slow``, the others in the default run."""


def case_names() -> list:
    """The set's cases."""
    return sorted(json.loads(KEY.read_text())["cases"]) if KEY.is_file() else []


def cases() -> list:
    """The set's cases as test parameters, those of LONGEST marked slow."""
    return [pytest.param(name, marks=pytest.mark.slow) if name in LONGEST else name for name in case_names()]


@pytest.fixture(scope="module")
def key():
    return json.loads(KEY.read_text())


@pytest.fixture(scope="module")
def backbones(tmp_path_factory):
    """freevib on every file of the set, once: case -> (backbone CSV, freevib's JSON record)."""
    folder = tmp_path_factory.mktemp("challenge")
    made = {}
    for case in case_names():
        ringdown = challenge_ringdown(case, folder)
        assert main(["freevib", str(ringdown), "--mode-hz", "170", "--out", str(folder / f"fv{case}")]) == 0
        made[case] = (next((folder / f"fv{case}").glob("*_backbone.csv")),
                      json.loads(next((folder / f"fv{case}").glob("*Hz.json")).read_text()))
    return made


def sizes(verdict: dict, ratio: float) -> dict:
    """The key's parameters as the loop's final model gives them (module docstring); the frequency shift and
    linear damping only where their effect was named (an estimated nominal fits them under its prior)."""
    model = verdict["final_model"]
    parameters, scale = model["parameters"], model["amplitude_scale"]
    found = {}
    if "stiffness_change" in verdict["added"]:
        found["mass"] = 1 / (1 + parameters["frequency_shift"]) ** 2
    if "linear_damping" in verdict["added"]:
        found["added_zeta"] = parameters["zeta_0"] - model["nominal_damping"]
    if "air_damping" in parameters:
        found["c_per_q"] = parameters["air_damping"] / scale * ratio
    if "cubic" in parameters:
        found["k_per_q2"] = parameters["cubic"] / 2 * ratio ** 2 / scale ** 2
    return found


EFFECT_OF = {"mass": "stiffness_change", "added_zeta": "linear_damping", "c_per_q": "amplitude_damping",
             "k_per_q2": "cubic_stiffening"}
FINDING_OF = {"second": "second_mode", "drift": "drift"}


@pytest.mark.parametrize("case", cases())
def test_challenge_file_with_the_keys_nominal(tmp_path, key, backbones, case):
    truth = key["cases"][case]["parameters"]
    backbone, _ = backbones[case]
    assert main(["discrepancy", str(backbone), *NOMINAL, "--out", str(tmp_path)]) == 0
    verdict = json.loads((tmp_path / "discrepancy.json").read_text())
    findings = {entry["name"]: entry for entry in verdict["findings"] if entry["outside_library"]}
    outside = {FINDING_OF[name] for name in truth if name in FINDING_OF}
    assert set(findings) == outside, verdict["findings"]
    if outside:
        assert verdict["unexplained"]
        if "second" in truth:
            ratio, share = truth["second"]
            evidence = findings["second_mode"]["evidence"]
            assert evidence["frequency_hz"] == pytest.approx(ratio * key["reference"]["stuck_frequency_hz"],
                                                             rel=5e-3)
            assert evidence["relative_amplitude"] == pytest.approx(share, rel=0.3)
        if "drift" in truth:
            evidence = next(entry["evidence"] for entry in verdict["findings"] if entry["name"] == "drift"
                            and entry["evidence"]["quantity"] == "natural_frequency_hz")
            assert evidence["clock"] == "time since each hit's impact"
            assert evidence["relative_change_over_span"] == pytest.approx(-truth["drift"], rel=0.3)
            # the backbone as at each hit's impact (the drift taken out): the effects of the truth, nothing else
            assert set(verdict["drift_correction"]) == {"natural_frequency_hz"}
            assert set(verdict["added"]) == {EFFECT_OF[name] for name in truth if name in EFFECT_OF}, verdict["added"]
        return
    assert not verdict["unexplained"], verdict["steps"][-1]["reduced_chi_squared"]
    assert set(verdict["added"]) == {EFFECT_OF[name] for name in truth if name in EFFECT_OF}
    found = sizes(verdict, key["reference"]["x_over_q_at_acc1"])
    for name in (name for name in truth if name in EFFECT_OF):
        if name == "mass":  # the size of a mass loading is its frequency change, 1 - 1 / sqrt(m)
            assert 1 - found[name] ** -0.5 == pytest.approx(1 - truth[name] ** -0.5, rel=SIZE)
        else:
            assert found[name] == pytest.approx(truth[name], rel=SIZE), name


OFFSETS = {"stiffness_change", "linear_damping"}


@pytest.mark.slow  # eight loops with the nominal's priors, several minutes
@pytest.mark.parametrize("case", cases())
def test_challenge_file_without_the_nominal(tmp_path, key, backbones, case):
    truth = key["cases"][case]["parameters"]
    backbone, _ = backbones[case]
    assert main(["discrepancy", str(backbone), "--out", str(tmp_path)]) == 0
    verdict = json.loads((tmp_path / "discrepancy.json").read_text())
    outside = {FINDING_OF[name] for name in truth if name in FINDING_OF}
    assert {entry["name"] for entry in verdict["findings"] if entry["outside_library"]} == outside
    if outside:
        assert verdict["unexplained"]
        return
    assert not verdict["unexplained"]
    expected = {EFFECT_OF[name] for name in truth if name in EFFECT_OF}
    answers = [set(verdict["added"])] + [{effect for effect in effects.split(", ") if not EFFECTS[effect].in_joint}
                                         for effects in verdict["alternatives"]]
    assert any(expected - OFFSETS <= answer <= expected for answer in answers), (verdict["added"],
                                                                                   verdict["alternatives"])
    found = sizes(verdict, key["reference"]["x_over_q_at_acc1"])
    for name in (name for name in truth if EFFECT_OF.get(name) in set(verdict["added"]) - OFFSETS):
        assert found[name] == pytest.approx(truth[name], rel=SIZE), name
    # an offset not named is reported as the nominal, within its stated uncertainty, and the verdict says so
    assert "cannot be told from it" in verdict["nominal_caveat"]
    reference = key["reference"]
    if "stiffness_change" not in verdict["added"]:
        loaded = reference["stuck_frequency_hz"] / truth.get("mass", 1.0) ** 0.5
        assert abs(verdict["nominal_frequency_hz"] - loaded) < 2 * verdict["nominal_frequency_standard_error_hz"]
    if "linear_damping" not in verdict["added"]:
        damped = reference["linear_damping"] + truth.get("added_zeta", 0.0)
        assert abs(verdict["nominal_damping"] - damped) < 2 * verdict["nominal_damping_standard_error"]
