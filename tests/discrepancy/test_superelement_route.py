"""The discrepancy loop on a structure's own superelement and friction models (``discrepancy.superelement_route``), on
the BRB with data of known content: the QSMA backbone of a true design with undeclared effects and noise at the
measurement's uncertainty. The candidates are the truth's design (in the friction model that holds it) among
random Table 3 designs: the loop's decisions, given starts in the truth's basin (the route's own screen of Table 3,
which the command uses, is checked on the measured ASB below).

- no effect beyond the Jenkins reference: nothing added;
- each effect (a structure-specific linear damping put in through QSMA's own linear damping; microslip and a
  stuck core as the true Iwan element; a stiffness change, damping growing with amplitude, cubic stiffening put on
  the backbone): the loop names it and the error of what it acts on falls to at most half;
- a stiction truth: microslip named, the residual at the noise (the refitted Iwan element needs no theta here);
- a ripple outside the library: "unexplained";
- a model that contains another starts from its optimum, where it has the same backbone;
- the same verdict from two studies of different seeds (slow).
"""

from dataclasses import replace

import numpy as np
import pytest

from nonlinear.condensation import joint_space
from nonlinear.joint import from_unit, parameter_limits, parameter_names
from nonlinear.qsma_vectorised import qsma_designs
from study.structures import measured_levels
from discrepancy.superelement_route import (StructureModel, contained_design, evaluate_candidates, refit,
                                            structure_discrepancy_loop)
from reduction.superelement import beam_superelement
from study.structures import qsma_measurement

LEVELS = np.geomspace(1e-7, 3e-5, 16)
ZETA0 = 1.6659e-3  # the borrowed (BRB Table 1) linear damping
# Per group (BRB layout: 3 groups) F_S (N), K_T (N/m), [chi, beta, [theta]], K_z (N/m), inside Table 3. The
# Jenkins joint sticks below q = 2e-6 m kg^0.5 and is deep in macroslip at the top level (-13 % in frequency).
JENKINS = np.array([12.0, 2e8, 5e9, 18.0, 3e8, 5e9, 24.0, 4e8, 5e9])
IWAN4 = np.array([4e3, 2e8, -0.4, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 5e9, 8e3, 4e8, -0.5, 0.3, 5e9])
IWAN5 = np.array([4e3, 2e8, -0.4, 0.5, 0.5, 5e9, 6e3, 3e8, -0.3, 1.0, 0.5, 5e9, 8e3, 4e8, -0.5, 0.3, 0.5, 5e9])
# The stuck core: weak Iwan elements (the Jenkins joint's slip forces) deep in macroslip at the top levels, each
# with a core K_c = K_T / 2 that never slips.
IWAN4_CORE = np.array([12.0, 2e8, -0.4, 0.5, 1e8, 5e9, 18.0, 3e8, -0.3, 1.0, 1.5e8, 5e9,
                       24.0, 4e8, -0.5, 0.3, 2e8, 5e9])
TRUTH = {"jenkins": JENKINS, "iwan4": IWAN4, "iwan5": IWAN5, "iwan4_core": IWAN4_CORE}


@pytest.fixture(scope="module")
def brb(beam_roms):
    return joint_space(beam_superelement(beam_roms / "BRB.npz"))


def candidates_with(space, true_model: str, models):
    """Each model's candidates: 12 random Table 3 designs (seeded), with the truth among the true model's; the
    Jenkins counterpart of an Iwan truth (same F_S, K_T, K_z) among the Jenkins designs, a near miss."""
    rng = np.random.default_rng(11)
    found = {}
    for model in models:
        limits = parameter_limits(model, 3)
        designs = from_unit(rng.random((12, len(limits[0]))), *limits)
        if model == true_model:
            designs = np.vstack([TRUTH[model], designs])
        elif model == "jenkins":
            counterpart = TRUTH[true_model].reshape(3, -1)[:, [0, 1, -1]].ravel()
            designs = np.vstack([counterpart, designs])
        labels = [f"design {i}" for i in range(len(designs))]
        found[model] = evaluate_candidates(space, model, designs, labels, LEVELS, ZETA0)
    return found


def measured(space, true_model: str, linear_damping=ZETA0, on_backbone=None, seed=0):
    """The true design's backbone, an effect put on it, and noise at the measurement's uncertainty floors."""
    backbone = qsma_measurement(space, "BRB", true_model, TRUTH[true_model], LEVELS, linear_damping)
    measurement = measured_levels(backbone, len(LEVELS), path="virtual BRB, undeclared effects")
    frequency, damping = measurement.frequency_hz, measurement.damping
    if on_backbone is not None:
        frequency, damping = on_backbone(measurement.amplitude / measurement.amplitude[-1], frequency, damping)
    rng = np.random.default_rng(seed)
    return replace(measurement, frequency_hz=frequency + rng.normal(0, 1, frequency.size) * measurement.sigma_frequency,
                   damping=damping + rng.normal(0, 1, damping.size) * measurement.sigma_damping)


CASES = {
    "linear_damping": ("jenkins", {"linear_damping": 2.5 * ZETA0}, ["damping_linf"]),
    "microslip": ("iwan4", {}, ["frequency_linf_hz", "damping_linf"]),
    "stiffness_change": ("jenkins", {"on_backbone": lambda s, f, z: (f * 1.01, z)}, ["frequency_linf_hz"]),
    "amplitude_damping": ("jenkins", {"on_backbone": lambda s, f, z: (f, z + 3e-3 * s)}, ["damping_linf"]),
    "cubic_stiffening": ("jenkins", {"on_backbone": lambda s, f, z: (np.sqrt(f ** 2 + 0.01 * f[0] ** 2 * s ** 2), z)},
                         ["frequency_linf_hz"]),
}


def test_reference_design_alone_adds_nothing(brb):
    verdict = structure_discrepancy_loop(measured(brb, "jenkins", seed=5), candidates_with(brb, "jenkins",
                                                                                          ("jenkins", "iwan4")), ZETA0, brb)
    assert verdict.effects == [] and not verdict.unexplained
    assert verdict.steps[0].fit.parameters["design"] == "jenkins, refitted from design 0"


@pytest.mark.parametrize("effect", sorted(CASES))
def test_each_effect_is_named_and_halves_the_error(brb, effect):
    true_model, options, quantities = CASES[effect]
    candidates = candidates_with(brb, true_model, ("jenkins", "iwan4"))
    verdict = structure_discrepancy_loop(measured(brb, true_model, **options), candidates, ZETA0, brb)
    assert verdict.effects == [effect] and not verdict.unexplained
    before, after = verdict.steps[0].errors, verdict.steps[-1].errors
    assert all(after[name] <= 0.5 * before[name] for name in quantities)


@pytest.mark.parametrize("factor", [1.004, 0.996])
def test_a_stiffness_change_the_joint_absorbs_is_not_named(brb, factor):
    """A 0.4 % frequency change outside the joint is within what the refitted Jenkins joint's stiffnesses and slip
    forces reproduce (chi^2/dof 0.74 at the noise, where 1 % leaves 21): nothing is named, nothing unexplained."""
    measurement = measured(brb, "jenkins", on_backbone=lambda s, f, z: (f * factor, z))
    verdict = structure_discrepancy_loop(measurement, candidates_with(brb, "jenkins", ("jenkins", "iwan4")), ZETA0,
                                         brb)
    assert verdict.effects == [] and not verdict.unexplained and verdict.steps[0].reduced_chi_squared < 1.5


def test_stiction_truth_is_explained_without_naming_more_than_the_points_carry(brb):
    """An iwan5 truth (theta 0.5 on every group) at 16 levels: the Iwan element refitted without stiction already
    reaches the measurement's noise, so the loop names microslip and does not add three theta's the points do not
    ask for (it never names stiction without the microslip it comes with)."""
    candidates = candidates_with(brb, "iwan5", ("jenkins", "iwan4", "iwan5"))
    verdict = structure_discrepancy_loop(measured(brb, "iwan5"), candidates, ZETA0, brb)
    assert "microslip" in verdict.effects and set(verdict.effects) <= {"microslip", "stiction"}
    assert not verdict.unexplained and verdict.steps[-1].reduced_chi_squared < 1.5


def test_a_stuck_core_is_named_with_the_microslip_it_comes_with(brb):
    candidates = candidates_with(brb, "iwan4_core", ("jenkins", "iwan4", "iwan4_core"))
    verdict = structure_discrepancy_loop(measured(brb, "iwan4_core"), candidates, ZETA0, brb)
    assert sorted(verdict.effects) == ["microslip", "stuck_core"] and not verdict.unexplained
    # refitted from the true design (design 0), then scanned where a coordinate scan lowers chi^2
    assert verdict.steps[-1].fit.parameters["design"] in ("iwan4_core, refitted from design 0",
                                                          "iwan4_core, refitted from design 0, scanned")
    assert verdict.steps[-1].reduced_chi_squared < 1.5


def test_two_effects_are_both_named(brb):
    candidates = candidates_with(brb, "iwan4", ("jenkins", "iwan4"))
    verdict = structure_discrepancy_loop(measured(brb, "iwan4", linear_damping=2.5 * ZETA0, seed=3), candidates,
                                         ZETA0, brb)
    assert sorted(verdict.effects) == ["linear_damping", "microslip"] and not verdict.unexplained


def test_ripple_outside_the_library_is_unexplained(brb):
    ripple = lambda s, f, z: (f * (1 + 1e-3 * np.sin(3 * np.log(s / s[0]))), z)  # noqa: E731
    verdict = structure_discrepancy_loop(measured(brb, "jenkins", on_backbone=ripple),
                                         candidates_with(brb, "jenkins", ("jenkins", "iwan4")), ZETA0, brb)
    assert verdict.unexplained


@pytest.mark.parametrize("model, effects", [("iwan4", ("microslip",)), ("iwan5", ("microslip", "stiction")),
                                            ("iwan4_core", ("microslip", "stuck_core"))])
def test_a_larger_model_starts_where_it_is_the_model_it_contains(brb, model, effects):
    """The start a model takes from the optimum of the model it contains (``contained_design``) has that
    optimum's backbone within a tenth of the measurement's standard uncertainty at every level (exactly for iwan5
    at theta = 1; Iwan at Table 3's chi and beta limits is Jenkins to 6e-6 in frequency; a core at K_c's 100 N/m
    floor is 3e-8 off), so the larger model's fit starts no worse than the smaller one's optimum."""
    measurement = measured(brb, "iwan4")
    inner = {"iwan4": "jenkins"}.get(model, "iwan4")
    inner_effects = () if inner == "jenkins" else ("microslip",)
    found = refit(StructureModel(measurement, brb, ZETA0), inner, 3, inner_effects, [("truth", TRUTH[inner], {})])
    label, design, _ = contained_design(found, model, 3)
    assert label.startswith(inner)
    both = evaluate_candidates(brb, model, design[None, :], ["contained"], measurement.amplitude, ZETA0)
    assert np.all(np.abs(both.frequency_hz[0] - found.frequency_hz) < 0.1 * measurement.sigma_frequency)
    assert np.all(np.abs(both.damping[0] - found.damping) < 0.1 * measurement.sigma_damping)


def test_refit_reaches_the_noise_from_a_design_that_misses(brb):
    """The route refits, it does not choose: from the truth's Iwan design with every slip force 40 % high and
    every tangential stiffness 40 % low (its backbone hundreds of standard uncertainties away), the weighted
    least-squares refit on the superelement fits the noisy measurement at least as well as the truth itself."""
    measurement = measured(brb, "iwan4", seed=4)
    start = IWAN4.reshape(3, -1) * np.array([1.4, 0.6, 1.0, 1.0, 1.0])
    both = evaluate_candidates(brb, "iwan4", np.vstack([start.ravel(), IWAN4]), ["off", "truth"], LEVELS, ZETA0)
    chi_squared = np.sum(((both.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2
                         + ((both.damping - measurement.damping) / measurement.sigma_damping) ** 2, axis=1)
    fit = refit(StructureModel(measurement, brb, ZETA0), "iwan4", 3, ("microslip",), [("off", start.ravel(), {})])
    assert chi_squared[0] > 100 * chi_squared[1] and fit.chi_squared <= chi_squared[1] * (1 + 1e-6)


def test_reference_model_is_required(brb):
    candidates = candidates_with(brb, "iwan4", ("iwan4",))
    with pytest.raises(ValueError, match="reference friction model 'jenkins'"):
        structure_discrepancy_loop(measured(brb, "iwan4"), candidates, ZETA0, brb)


@pytest.fixture(scope="module")
def small_asb_study(tmp_path_factory):
    """A small study of the ASB on its measured backbones (Jenkins and Iwan), through the study's command."""
    from cli.console import main as surrogacy
    from locations import ASB_MODELS

    data = ASB_MODELS.parent
    if not (data / "asb-backbones").is_dir():
        pytest.skip(f"ASB data not available at {data} (shared data folder absent)")
    out = tmp_path_factory.mktemp("study") / "study-asb"
    assert surrogacy(["study", "--out", str(out), "--data", str(data), "--set", "study.dataset=asb",
                      "--set", "sample.n_designs=2000", "--set", "sample.chunk_size=1000",
                      "--set", 'study.models=["jenkins", "iwan4"]', "--set", "pareto.generations=3",
                      "--set", "pareto.population=16", "--steps", "measurements", "explore", "analyse"]) == 0
    return out


def test_command_on_a_study_structure(small_asb_study, tmp_path, capsys):
    """``surrogacy discrepancy --study --structure``: the reference is a study's Jenkins design refitted on the
    structure's superelement, at least as good as the study's best (chi^2 recomputed here from the report's
    parameters by QSMA), and every step's errors are in the report."""
    import json

    from cli.console import main as surrogacy
    from discrepancy.superelement_route import from_study

    out = tmp_path / "C1"
    assert surrogacy(["discrepancy", "--study", str(small_asb_study), "--structure", "ASB C1", "--out", str(out)]) == 0
    record = json.loads((out / "discrepancy.json").read_text())
    assert record["structure"] == "ASB C1" and record["provenance"] == "measured"
    assert record["candidates"]["jenkins"] > 0 and record["candidates"]["iwan4"] > 0
    reference = record["steps"][0]
    assert reference["effect"] is None and reference["parameters"]["design"].startswith("jenkins, refitted from ")
    loaded = from_study(small_asb_study, "ASB C1")
    measurement, jenkins = loaded.measurement, loaded.candidates["jenkins"]

    def chi_squared(frequency_hz, damping):
        return np.sum(((frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2
                      + ((damping - measurement.damping) / measurement.sigma_damping) ** 2, axis=-1)

    design = [reference["parameters"][name] for name in parameter_names("jenkins", jenkins.n_groups)]
    refitted = qsma_designs(loaded.space, "jenkins", np.array([design]), amplitudes=measurement.amplitude,
                            linear_damping=loaded.borrowed_damping)
    recomputed = chi_squared(refitted.frequency[0] / (2 * np.pi), refitted.damping[0])
    n = 2 * len(measurement.amplitude)
    assert recomputed == pytest.approx(reference["reduced_chi_squared"] * (n - len(design)), rel=1e-9)
    assert recomputed <= np.min(chi_squared(jenkins.frequency_hz, jenkins.damping))
    text = (out / "discrepancy.md").read_text()
    assert "reference: jenkins, refitted from" in text
    assert len([line for line in text.splitlines() if line.startswith("| ") and line[2].isdigit()]) == \
        len(record["steps"])
    assert "joint law" in capsys.readouterr().out


@pytest.mark.parametrize("arguments, message", [
    (["--structure", "ASB C9"], "structure 'ASB C9' not in the study"),
    ([], "--study needs --structure"),
    (["--structure", "ASB C1", "extra.csv"], "give either FILE"),
])
def test_command_refuses_bad_study_requests(small_asb_study, tmp_path, capsys, arguments, message):
    from cli.console import main as surrogacy

    out = tmp_path / "out"
    assert surrogacy(["discrepancy", "--study", str(small_asb_study), *arguments, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists() or not any(path.name != ".lock" for path in out.iterdir())


@pytest.mark.slow
def test_the_verdict_does_not_depend_on_the_study_seed(small_asb_study, tmp_path):
    """The route's fits start from its own screen, not from a study's random sample: a study of another seed gives
    the same discrepancy.json (every step, parameter and verdict), the study's folder aside."""
    import json

    from cli.console import main as surrogacy
    from locations import ASB_MODELS

    other = tmp_path / "study-seed-7"
    assert surrogacy(["study", "--out", str(other), "--data", str(ASB_MODELS.parent), "--set", "study.dataset=asb",
                      "--set", "sample.n_designs=2000", "--set", "sample.chunk_size=1000", "--set", "sample.seed=7",
                      "--set", 'study.models=["jenkins", "iwan4"]', "--set", "pareto.generations=3",
                      "--set", "pareto.population=16", "--steps", "measurements", "explore", "analyse"]) == 0
    records = []
    for study in (small_asb_study, other):
        out = tmp_path / study.name / "C4"
        assert surrogacy(["discrepancy", "--study", str(study), "--structure", "ASB C4", "--out", str(out)]) == 0
        record = json.loads((out / "discrepancy.json").read_text())
        records.append({key: value for key, value in record.items() if key != "study"})
    assert records[0] == records[1]
