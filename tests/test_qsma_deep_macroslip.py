"""QSMA deep in macroslip on the project's own beams: Table 3 designs whose weak patches slide thousands of slip
displacements while one element holds the joint's mechanism (a uniform slide, the twist).

The cases of the regression list came from `make rom`'s BRB superelement: the compiled kernel once reported
non-equilibria there as converged (an iterate run off along the uniform slide, omega 12 times and zeta 1e5 times
too large) and gave up on levels that have solutions. Their reference values are 40-digit solutions (the issue's,
reproduced by ``extended_precision``). The default-mesh superelements are built by the pipeline's own stages into
build/ (cached: `make rom` has usually made them; about 6 minutes when not).
"""

from pathlib import Path

import mpmath
import numpy as np
import pytest

from extended_precision import ReferenceDesign
from nonlinear.condensation import joint_mechanisms, joint_space, stuck_modes
from nonlinear.joint import (patch_elements, random_designs, slip_displacement, stuck_stiffness, tangential_elements,
                             tangential_force, tangential_rows)
from nonlinear.qsma import qsma_reference
from nonlinear.qsma_vectorised import qsma_designs
from pipeline.cli import main as surrogacy
from reduction.superelement import load_superelement

BUILD = Path(__file__).resolve().parents[1] / "build"
LINEAR_DAMPING = 1e-3
# Issue 12's regression cases: model, design (groups {1, 5}, {2, 4}, {3}), {q: (omega rad/s, zeta)} on the BRB.
REGRESSION_CASES = [
    ("iwan4", [15077569.45561209, 1252196466887.063, -0.459996818495245, 4889.320403581977, 4445485557795.587,
               81129.69557265747, 70071043197.98123, -0.8321271581552883, 0.00784928209729223, 3283482084890.8633,
               7588.236357303559, 14940216705562.04, -0.8263542495010822, 0.6991119406175521, 17107.698714196253],
     {4.422088191680361: (1001.76237214, 8.809577e-02), 7.180483944291691: (953.93141459, 7.773062e-02)}),
    ("iwan4", [6450681.413051226, 33242209344.485035, -0.8929355574748911, 0.0005132832880507831, 241.88421693987144,
               102969235.36191155, 410817358755.8273, -0.8799385268696787, 4034.73454797796, 1883539040839.5708,
               19001.453924202804, 34548930940.49994, -0.5929469553565201, 0.00012585561921398238,
               1413505.9733887909],
     {27.3963767052427: (861.75073681, 3.773453e-02), 44.485599232024825: (830.15714202, 4.642237e-02),
      72.23468126183361: (810.08744448, 3.875854e-02), 117.29299519567691: (797.47628768, 2.827518e-02)}),
    ("jenkins", [2395708.9026956246, 7942577490088.069, 428.0186042764309, 19.06653498842162, 224.85988207085674,
                 188716.77477128472, 459.35587462863066, 41627079288049.35, 199785730131.3333],
     {33.26727637153555: (167.97435340, 3.422564e-03), 54.01862954826198: (167.75951909, 2.925955e-03),
      87.71419414332043: (167.62707677, 2.351390e-03), 142.42826814660737: (167.54546021, 1.895103e-03)}),
]


@pytest.fixture(scope="module")
def beam_spaces():
    """Joint spaces of the three default-mesh superelements, built by the pipeline's stages when absent."""
    if not all((BUILD / "rom" / f"{beam}.npz").exists() for beam in ("BRB", "LBRB", "SBRB")):
        assert surrogacy(["beams", "--out", str(BUILD / "beams"), "--no-render"]) == 0
        assert surrogacy(["fe", "--beams", str(BUILD / "beams"), "--out", str(BUILD / "fe")]) == 0
        assert surrogacy(["rom", "--beams", str(BUILD / "beams"), "--fe", str(BUILD / "fe"),
                          "--out", str(BUILD / "rom")]) == 0
    return {beam: joint_space(load_superelement(BUILD / "rom" / f"{beam}.npz")) for beam in ("BRB", "LBRB", "SBRB")}


def slip_amplitude(space, model, design) -> float:
    """q_slip: the modal amplitude at which the weakest element reaches macroslip in the stuck mode (m kg^0.5)."""
    elements = patch_elements(model, np.asarray(design, dtype=float)[None, :], space.superelement.patch_groups)
    rows = tangential_rows(space.superelement.n_patches)
    joint_shape = stuck_modes(space, stuck_stiffness(elements), rows=rows).joint_shape[0, rows]
    return float(np.min(slip_displacement(tangential_elements(elements))[0] / np.abs(joint_shape)))


def regression_levels(space, model, design, reference):
    """The case's 20 levels q_slip geomspace(1e-3, 10, 20), scaled so that its listed amplitudes are exact (the
    rebuilt superelement's q_slip differs from the one of the issue by about 3e-10)."""
    levels = slip_amplitude(space, model, design) * np.geomspace(1e-3, 10.0, 20)
    first = min(reference)
    levels *= first / levels[np.argmin(np.abs(levels / first - 1))]
    for amplitude in reference:  # the listed ones to the last bit
        levels[np.argmin(np.abs(levels / amplitude - 1))] = amplitude
    return levels


def mechanism_imbalance(space, model, designs, result):
    """(designs, levels) |d^T f - alpha rigid^T psi| / (sum |f| + |alpha| sum |rigid^T psi|) from the returned
    joint motion, in numpy with the elements' backbones (``tangential_force``, not the kernel's code), less what the condensed problem
    resolves: a holding element (below macroslip, or stuck) has its motion to 2e-9 of the largest (the
    condensation's accuracy and the residual's acceptance), so its force to K_T 2e-9 max|r|. An element that slid
    away along a mechanism is off by whole slip forces."""
    elements = patch_elements(model, designs, space.superelement.patch_groups)
    tangential = tangential_elements(elements)
    rows = tangential_rows(space.superelement.n_patches)
    modes = stuck_modes(space, stuck_stiffness(elements), rows=rows)
    mechanisms = joint_mechanisms(space)
    per_level = tangential._replace(**{name: getattr(tangential, name)[:, None, :] for name in
                                       ("slip_force", "stiffness", "chi", "beta", "theta", "normal_stiffness")})
    r = result.joint_displacement
    force = tangential_force(per_level, r)
    load = result.force[..., None] * (modes.shape @ mechanisms.rigid.T)[:, None, :]
    imbalance = np.abs(force @ mechanisms.tangential.T - load)
    holding = tangential.stuck | (np.abs(r) < slip_displacement(tangential)[:, None, :])
    resolved = 2e-9 * np.abs(r).max(axis=-1, keepdims=True) * np.where(holding, per_level.stiffness, 0.0)
    floor = resolved @ np.abs(mechanisms.tangential.T)
    return (np.maximum(imbalance - floor, 0.0).max(axis=-1)
            / (np.abs(force).sum(axis=-1) + np.abs(load).sum(axis=-1)))


def test_joint_mechanisms_are_rigid_slides_and_twist(beam_spaces):
    """The BRB's lap is flat and its patch centres collinear along x: three tangential mechanisms (the slides in x
    and y, the twist about z, with y motion proportional to the patch's x), orthonormal, no normal joint motion,
    and each a rigid-body motion of the unjoined halves (zero strain energy)."""
    space = beam_spaces["BRB"]
    mechanisms = joint_mechanisms(space)
    assert mechanisms.tangential.shape == (3, 10)
    np.testing.assert_allclose(mechanisms.tangential @ mechanisms.tangential.T, np.eye(3), atol=1e-12)
    joint = space.joint_modes @ mechanisms.rigid.T
    assert np.abs(joint[2::3]).max() <= 1e-9
    assert np.all(space.eigenvalues[np.any(mechanisms.rigid != 0, axis=0)] < (2 * np.pi) ** 2)
    slides = np.zeros((2, 10))
    slides[0, 0::2] = slides[1, 1::2] = 1 / np.sqrt(5)  # uniform x and y slides (x and y are one subspace: equal
    within = slides @ mechanisms.tangential.T  # singular values, so the basis may turn within it)
    np.testing.assert_allclose(np.linalg.norm(within, axis=1), 1.0, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("model, design, reference", REGRESSION_CASES)
def test_regression_cases_converge_to_the_40_digit_solutions(beam_spaces, model, design, reference):
    """No level of the case is reported converged off its solution: each is converged or flagged with a reason,
    and a converged listed level equals the 40-digit value within 1e-8 in omega and 1e-6 in zeta (the values
    carry 12 and 7 digits). The extended-precision reference on this build's BRB agrees with them as closely as
    their printed digits allow, its full equations holding to 1e-20 of their largest term (40 digits less the
    cancellation of stuck joint forces against slip deficits 1e4 slip displacements deep). About 45 s a case,
    most of it the extended-precision set-up. (Still open, issue 12: the Jenkins case's level 17 is flagged "not
    converged" or not depending on the last bit of the levels; every level converging is what
    ``test_share_of_flagged_deep_levels_is_below_the_target`` waits for.)"""
    space = beam_spaces["BRB"]
    levels = regression_levels(space, model, design, reference)
    result = qsma_designs(space, model, np.array(design)[None, :], amplitudes=levels, linear_damping=LINEAR_DAMPING)
    assert np.all((result.reason == "") == result.converged)
    assert result.converged.mean() >= 0.9
    extended = ReferenceDesign(space, model, design)
    for amplitude, (frequency, damping) in reference.items():
        level = int(np.argmin(np.abs(levels - amplitude)))
        assert levels[level] == amplitude
        if result.converged[0, level]:
            assert abs(result.frequency[0, level] / frequency - 1) <= 1e-8
            assert abs(result.damping[0, level] / damping - 1) <= 1e-6
        r, steps = extended.solve(amplitude, mpmath.mpf(amplitude) * extended.joint_shape)
        exact = extended.level(amplitude, r, steps, LINEAR_DAMPING)
        assert exact.full_residual <= 1e-20
        assert abs(exact.frequency / frequency - 1) <= 1e-10
        assert abs(exact.damping / damping - 1) <= 3e-7  # 7 printed digits of zeta: half a unit is 2.6e-7 at 1.9e-3
        if result.converged[0, level]:
            assert abs(result.frequency[0, level] / exact.frequency - 1) <= 1e-8
            assert abs(result.damping[0, level] / exact.damping - 1) <= 1e-6


def deep_levels(space, model, design, n_levels=16):
    """From the stuck regime to 1e4 slip displacements of the weakest element."""
    return slip_amplitude(space, model, design) * np.geomspace(1e-3, 1e4, n_levels)


def sweep(space, model, n_designs, seed):
    """Each design alone at its own deep levels: the kernel's result, the oracle's and the force imbalance."""
    designs = random_designs(model, n_designs, 3, np.random.default_rng(seed))
    rows = []
    for design in designs:
        levels = deep_levels(space, model, design)
        vectorised = qsma_designs(space, model, design[None, :], amplitudes=levels, linear_damping=LINEAR_DAMPING)
        oracle = qsma_reference(space, model, design, amplitudes=levels, linear_damping=LINEAR_DAMPING)
        rows.append((vectorised, oracle, mechanism_imbalance(space, model, design[None, :], vectorised)[0]))
    return designs, rows


@pytest.mark.slow
@pytest.mark.parametrize("beam", ["BRB", "LBRB", "SBRB"])
@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan4_stuck"])
def test_no_level_reported_converged_is_off_equilibrium_on_the_beams(beam_spaces, beam, model):
    """40 Table 3 designs per beam and convex model, 16 levels each from 1e-3 to 1e4 times the weakest element's
    macroslip amplitude: every level the kernel reports converged balances the slip forces on the joint's
    mechanisms within 1e-9 (checked here in numpy), agrees with the oracle within 1e-8 in omega and 1e-6 in zeta
    wherever the oracle also converged and its own forces balance (the oracle accepts on the condensed residual
    alone, and runs off along the slide on some of these levels), and every level that fails says why (about 40 s
    per beam and model)."""
    space = beam_spaces[beam]
    designs, rows = sweep(space, model, 40, seed=12)
    failed = 0
    for design, (vectorised, oracle, imbalance) in zip(designs, rows):
        converged = vectorised.converged[0]
        failed += np.sum(~converged)
        assert np.all(vectorised.reason[0, ~converged] != "")
        assert np.all(imbalance[converged] <= 1e-9)
        oracle_result = type(vectorised)(*(np.asarray(field)[None] for field in oracle))
        oracle_balanced = mechanism_imbalance(space, model, design[None, :], oracle_result)[0] <= 1e-9
        both = converged & oracle.converged & oracle_balanced
        np.testing.assert_allclose(vectorised.frequency[0, both], oracle.frequency[both], rtol=1e-8)
        np.testing.assert_allclose(vectorised.damping[0, both], oracle.damping[both], rtol=1e-6)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 12 open: 2-4 % of these deep levels are flagged (forces unbalanced "
                                       "beyond the condensation's accuracy, or not converged); the target is 0.01 %")
@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan4_stuck"])
def test_share_of_flagged_deep_levels_is_below_the_target(beam_spaces, model):
    """Of 40 designs x 16 deep levels on the BRB, at most 0.01 % flagged (none of 640)."""
    space = beam_spaces["BRB"]
    designs = random_designs(model, 40, 3, np.random.default_rng(12))
    flagged = sum(np.sum(~qsma_designs(space, model, design[None, :], amplitudes=deep_levels(space, model, design),
                                       linear_damping=LINEAR_DAMPING).converged) for design in designs)
    assert flagged <= 1e-4 * len(designs) * 16
