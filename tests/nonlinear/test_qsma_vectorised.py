"""Vectorised QSMA against the single-design oracle on random designs from the paper's Table 3.

The two share the physics (joint-space condensation, element laws) but not the numerics: the oracle forms
the stuck mode by a dense eigen-solve refined by Rayleigh quotient iteration with an energy quotient (the
dense solve alone is off by up to eps ||Lambda + Phi^T K_d Phi||, 1e-6 of the eigenvalue on stiff designs;
refined, 1e-12) and the compliance by a linear solve, and uses MINPACK's hybrid method with finite
differences; the vectorised version takes both from the small exact stuck eigenproblem
(``nonlinear.stuck_modes``) and runs a compiled (numba) damped Newton on the potential energy. Agreement is
required within 1e-10 in the stuck frequency, and within 1e-6 in omega and 1e-5 in zeta where both converge.
For the convex laws (Jenkins, four-parameter Iwan) the equilibrium is unique; the stiction law (five-parameter Iwan,
theta < 1) can soften faster than the joint's stiffness, after which several equilibria exist, so it is
compared only while every element's backbone tangent is still positive along the loading path.
"""

import numpy as np
import pytest

from nonlinear import slip_laws
from nonlinear.condensation import UNAMBIGUOUS_MAC, StuckModeCache, joint_space, stuck_modes
from nonlinear.joint import (patch_elements, random_designs, scaled_law, stuck_stiffness, tangential_elements,
                             tangential_rows, tangential_tangent)
from nonlinear.qsma import JUMPED, MACROSLIP, PAST_JUMP, qsma_reference
from nonlinear.qsma_kernel import (MACROSLIP_SLOPE, N_LAW, NEAR, STICTION, _convex_between, _law_table,
                                   _slip_power, slip_law)
from nonlinear.qsma_vectorised import qsma_designs
from reduction.superelement import beam_superelement
from extended_precision import reference_levels
from test_qsma import REDUCED_MASS, two_body_space
from test_stuck_modes import full_target_mode

AMPLITUDES = np.logspace(-7, -4, 10)  # m kg^0.5: the ASB's measured range is 7e-6 to 1.1e-4
LINEAR_DAMPING = 7e-4


@pytest.fixture
def cd1_space(asb_superelement):
    return joint_space(asb_superelement("CD1"))


def unique_equilibrium(model, designs, result, patch_groups):
    """(designs, levels) mask: every element's backbone tangent stayed positive up to this level."""
    if model != "iwan5":
        return np.ones(result.converged.shape, dtype=bool)
    tangential = tangential_elements(patch_elements(model, designs, patch_groups))
    per_level = tangential._replace(**{name: getattr(tangential, name)[:, None, :] for name in
                                       ("slip_force", "stiffness", "chi", "beta", "theta", "normal_stiffness",
                                        "core_stiffness")})
    rising = np.all(tangential_tangent(per_level, np.nan_to_num(result.joint_displacement)) > 0.0, axis=-1)
    return np.cumprod(rising, axis=1).astype(bool)


def compare_with_oracle(space, model, n_designs, seed):
    designs = random_designs(model, n_designs, 3, np.random.default_rng(seed))
    compare_designs_with_oracle(space, model, designs)


def compare_designs_with_oracle(space, model, designs):
    n_designs = len(designs)
    vectorised = qsma_designs(space, model, designs, amplitudes=AMPLITUDES, linear_damping=LINEAR_DAMPING)
    oracle = [qsma_reference(space, model, design, amplitudes=AMPLITUDES, linear_damping=LINEAR_DAMPING)
              for design in designs]
    oracle_converged = np.array([result.converged for result in oracle])
    # levels at or past a jump of the loading path (stiction) are a verdict on the design, not a failure: both
    # flag the same ones, up to an oracle that fails at the jump's level instead, or stops on another equilibrium
    # that does not cross (MINPACK's hybrid method is no descent method; measured: 2 of 1,000 CD1 designs), where
    # the 40-digit loading path decides
    path_jumps = np.isin(vectorised.reason, (JUMPED, PAST_JUMP))
    oracle_jumps = np.isin(np.array([result.reason for result in oracle]), (JUMPED, PAST_JUMP))
    disputed = np.flatnonzero(np.any(oracle_converged & path_jumps | vectorised.converged & oracle_jumps, axis=1))
    assert len(disputed) <= 0.01 * n_designs
    for design in disputed:
        first = int(np.argmax(path_jumps[design] | oracle_jumps[design]))
        _, reason = reference_levels(space, model, designs[design], AMPLITUDES[:first + 1], LINEAR_DAMPING)
        assert (reason == JUMPED) == path_jumps[design, first]
    assert (vectorised.converged | path_jumps).mean() > 0.99
    assert (oracle_converged | path_jumps).mean() > 0.95
    both = vectorised.converged & oracle_converged
    both &= unique_equilibrium(model, designs, vectorised, space.superelement.patch_groups)
    assert both.mean() > 0.8
    oracle_stuck = np.array([result.stuck_frequency for result in oracle])
    assert np.all(np.abs(vectorised.stuck_frequency / oracle_stuck - 1) <= 1e-10)
    frequency_error = np.abs(vectorised.frequency[both] / np.array([r.frequency for r in oracle])[both] - 1)
    assert np.all(frequency_error <= 1e-6)
    damping_error = np.abs(vectorised.damping[both] / np.array([r.damping for r in oracle])[both] - 1)
    assert np.all(damping_error <= 1e-5)
    for name in ("converged", "reason", "mac"):
        assert getattr(vectorised, name).shape[0] == n_designs


@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan5", "iwan4_stuck", "iwan4_core"])
def test_vectorised_qsma_equals_oracle_on_table3_designs(model, cd1_space):
    """60 designs per model (about 10 s in all)."""
    compare_with_oracle(cd1_space, model, 60, seed=11)


@pytest.mark.parametrize("model", ["iwan4", "iwan5"])
def test_vectorised_qsma_equals_oracle_on_the_prestressed_beam(model, beam_roms):
    """The BRB's prestressed superelement with the joint's rotational rows (25 joint rows, negative free modes
    that only the joint holds): 40 Table 3 designs less those flagged unstable, whose count is a dense solve's
    (tests/reduction/test_prestressed_joint.py); about 10 s."""
    space = joint_space(beam_superelement(beam_roms / "BRB.npz"))
    designs = random_designs(model, 40, 3, np.random.default_rng(13))
    stable = stuck_modes(space, stuck_stiffness(patch_elements(model, designs, space.superelement.patch_groups)))
    compare_designs_with_oracle(space, model, designs[stable.unstable == 0])


@pytest.mark.slow
@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan5", "iwan4_stuck", "iwan4_core"])
def test_vectorised_qsma_equals_oracle_on_1000_table3_designs(model, cd1_space):
    """1,000 designs per model: 11 s (Jenkins) to 45 s (five-parameter Iwan) per model on one core, nearly all
    of it the oracle."""
    compare_with_oracle(cd1_space, model, 1000, seed=12)


def test_vectorised_force_control_flags_macroslip():
    """Two rigid bodies joined by a Jenkins element: the modal force saturates at alpha_crit = F_S / (mu b)
    with b = 1 / sqrt(mu); above it no static equilibrium exists, and those levels are flagged, not dropped,
    while amplitude control reaches any amplitude."""
    space = two_body_space()
    slip_force, stiffness = 300.0, 2.0e6
    design = np.array([[slip_force, stiffness, 1.0e7]])
    critical = slip_force / np.sqrt(REDUCED_MASS)
    by_force = qsma_designs(space, "jenkins", design, forces=critical * np.array([0.5, 0.99, 1.01, 2.0]))
    np.testing.assert_array_equal(by_force.converged[0], [True, True, False, False])
    np.testing.assert_array_equal(by_force.reason[0, 2:], MACROSLIP)
    assert np.all(np.isnan(by_force.frequency[0, 2:]))
    by_amplitude = qsma_designs(space, "jenkins", design, amplitudes=np.sqrt(REDUCED_MASS) * slip_force / stiffness
                                * np.array([0.5, 2.0, 100.0]))
    assert by_amplitude.converged.all()
    np.testing.assert_allclose(by_amplitude.force[0, 1:], critical, rtol=1e-12)


@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan4_core"])
def test_vectorised_force_control_retraces_amplitude_control(model, cd1_space):
    """Each design loaded by the modal forces that amplitude control found returns the same amplitudes,
    frequencies and damping (the convex laws have one equilibrium per force below macroslip)."""
    space = cd1_space
    designs = random_designs(model, 40, 3, np.random.default_rng(5))
    by_amplitude = qsma_designs(space, model, designs, amplitudes=AMPLITUDES, linear_damping=LINEAR_DAMPING)
    assert by_amplitude.converged.mean() > 0.99
    for design, forces, damping, usable in zip(designs, by_amplitude.force, by_amplitude.damping,
                                               by_amplitude.converged):
        by_force = qsma_designs(space, model, design[None, :], forces=forces[usable], linear_damping=LINEAR_DAMPING)
        assert by_force.converged.all()
        np.testing.assert_allclose(by_force.amplitude[0], AMPLITUDES[usable], rtol=1e-8)
        np.testing.assert_allclose(by_force.damping[0], damping[usable], rtol=1e-7)


@pytest.mark.parametrize("model", ["jenkins", "iwan4", "iwan5"])
def test_compiled_slip_law_is_the_slip_laws_module(model):
    """The kernel's fused evaluation (one power per element) gives ``nonlinear.slip_laws``' deficit, slope
    (clipped at K_T phi_max) and potential on Table 3 elements from stuck to deep macroslip."""
    law = scaled_law(tangential_elements(patch_elements(model, random_designs(model, 200, 3,
                                                                              np.random.default_rng(4)))))
    constants = [np.ravel(a) for a in law[1:]]
    x = np.random.default_rng(5).choice([-1, 1], constants[0].size) * np.geomspace(1e-6, 1e3, constants[0].size)
    fused = np.array([slip_law(*values) for values in zip(x, *constants)])
    np.testing.assert_allclose(fused[:, 0], slip_laws.slip_deficit(x, *constants), rtol=1e-13, atol=0)
    slope = np.minimum(slip_laws.slip_deficit_slope(x, *constants), constants[1] + constants[0] / (constants[2] + 1))
    np.testing.assert_allclose(fused[:, 1], slope, rtol=1e-13, atol=0)
    np.testing.assert_allclose(fused[:, 2], slip_laws.slip_deficit_potential(x, *constants), rtol=1e-13, atol=0)


def test_slip_power_from_a_nearby_base_is_the_power_itself():
    """The Newton trial's slip power r |x|^(chi+1) from the iterate's by the binomial series is as accurate as
    the direct power (``qsma_kernel._power``: within (2 + |(chi+1) log2 |x||) ulp of the exact value, here
    x87 extended precision, and one more for the factor r), give or take 2 ulp, for every exponent of Table
    3's range and relative changes of |x| up to NEAR (either sign, either side of the base); where the change
    is larger or an end is in macroslip it is the direct power."""
    rng = np.random.default_rng(6)
    for _ in range(2000):
        exponent, r = rng.uniform(1e-3, 1.0), 10 ** rng.uniform(-20, 37)
        base = rng.choice([-1, 1]) * 10 ** rng.uniform(-12, -1e-3)
        delta = rng.choice([-1, 1]) * 10 ** rng.uniform(-16, np.log10(NEAR))
        x = base * (1 + delta)
        exact = float(np.longdouble(r) * np.abs(np.longdouble(x)) ** np.longdouble(exponent))
        bound = (3 + abs(exponent * np.log2(abs(x)))) * np.spacing(exact)
        assert abs(_slip_power(x, exponent, r) - exact) <= bound
        series = _slip_power(x, exponent, r, base, _slip_power(base, exponent, r))
        assert abs(series - exact) <= bound + 2 * np.spacing(exact), (exponent, base, delta)
    base = 0.5
    for x in (base * (1 + 3 * NEAR), 1.0 + 1e-9):  # too far, or in macroslip: the direct power, exactly
        assert _slip_power(x, 0.4, 2.0, base, 123.0) == _slip_power(x, 0.4, 2.0)


def test_energy_is_convex_where_the_kernel_skips_the_energy_test():
    """Where ``_convex_between`` says a five-parameter Iwan element (theta < 1) is convex between two slips, its
    share of the energy, h(x) = K_T phi_max x^2 / 2 - G(x), is convex on the segment (h' = K_T phi_max x - g
    non-decreasing on a fine grid; C^+ >= diag(K_T), so E is then convex too); a segment across the stiction
    drop at |x| = 1 is never passed."""
    designs = random_designs("iwan5", 300, 3, np.random.default_rng(11))
    law = scaled_law(tangential_elements(patch_elements("iwan5", designs)))
    constants = [np.ravel(a) for a in law[1:]]
    table = np.empty((constants[0].size, N_LAW))
    _law_table(*constants, table)
    rng = np.random.default_rng(12)
    ends = rng.choice([-1, 1], (2, constants[0].size)) * np.exp(rng.uniform(np.log(0.05), np.log(3.0),
                                                                              (2, constants[0].size)))
    passed = crossing = 0
    for i, (start, end) in enumerate(ends.T):
        values = [slip_law(x, *(c[i] for c in constants)) for x in (start, end)]
        convex = _convex_between(np.array([start]), np.array([end]), np.array([values[0][1]]),
                                 np.array([values[1][1]]), table[i:i + 1])
        straddles = min(abs(start), abs(end)) < 1.0 < max(abs(start), abs(end)) or start * end < 0 and max(
            abs(start), abs(end)) > 1.0
        crossing += straddles
        if not convex:
            continue
        assert not (straddles and table[i, STICTION] > 0.0)
        passed += 1
        grid = np.linspace(start, end, 2001) * (1 - 1e-12)
        derivative = table[i, MACROSLIP_SLOPE] * grid - np.array([slip_law(x, *(c[i] for c in constants))[0]
                                                                   for x in grid])
        increments = np.diff(derivative) * np.sign(end - start)
        assert increments.min() >= -1e-12 * np.abs(derivative).max()
    assert passed > 100 and crossing > 30


def test_vectorised_low_amplitude_limit_is_the_linear_mode(cd1_space):
    """Jenkins joints below their smallest slip displacement (Table 3: F_S / K_T >= 1e-13 m; here r ~ 1e-16 m)
    are linear: omega equals the stuck eigenfrequency, which equals the full eigen-solve's (within 1e-6)."""
    space = cd1_space
    designs = random_designs("jenkins", 40, 3, np.random.default_rng(8))
    result = qsma_designs(space, "jenkins", designs, amplitudes=[1e-16, 2e-16])
    unambiguous = result.mac > UNAMBIGUOUS_MAC  # the others are flagged
    assert unambiguous.mean() > 0.9 and result.converged[unambiguous].all()
    frequency = result.frequency[unambiguous]
    np.testing.assert_allclose(frequency, result.stuck_frequency[unambiguous, None] * np.ones(2), rtol=1e-12)
    stiffness = stuck_stiffness(patch_elements("jenkins", designs[unambiguous], space.superelement.patch_groups))
    full = np.array([full_target_mode(space, k)[0] for k in stiffness])
    np.testing.assert_allclose(frequency[:, 0], np.sqrt(full), rtol=1e-6)


@pytest.mark.parametrize("model, design", [("iwan4_stuck", 3876), ("iwan5", 607), ("iwan4", 1847)])
def test_vectorised_qsma_converges_where_newton_straddles_a_kink_of_the_slip_law(model, design, cd1_space):
    """Designs of the benchmark (``benchmarks.qsma``: 4,000 designs, seed 0, 30 levels) on which the damped Newton
    once failed: an element next to macroslip (chi = -0.97) whose iterates cycled across |x| = 1, the full steps
    that halve |R| undoing the energy's descent; a softening stiction element (theta < 1) whose clipped slope
    left Newton only linearly convergent; and one that crawls through 60 energy-descent steps unless full steps
    that halve the level's smallest |R| are taken. Every level converges, equal to the oracle where it
    converges (the oracle misses some of these levels), but where the loading path jumps: the stiction design's
    element 2 crosses macroslip past level 6 (the levels from there on are flagged, the oracle's too)."""
    space = cd1_space
    chosen = random_designs(model, 4000, 3, np.random.default_rng(0))[design]
    amplitudes = np.geomspace(7e-6, 1.1e-4, 30)
    vectorised = qsma_designs(space, model, chosen[None, :], amplitudes=amplitudes, linear_damping=1e-3)
    oracle = qsma_reference(space, model, chosen, amplitudes=amplitudes, linear_damping=1e-3)
    path_jumps = np.isin(vectorised.reason[0], (JUMPED, PAST_JUMP))
    assert np.all(vectorised.converged[0] | path_jumps) and not oracle.converged[path_jumps].any()
    both = oracle.converged
    assert both.sum() >= min(20, vectorised.converged.sum())
    np.testing.assert_allclose(vectorised.frequency[0, both], oracle.frequency[both], rtol=1e-6)
    np.testing.assert_allclose(vectorised.damping[0, both], oracle.damping[both], rtol=1e-5)


def test_shared_stuck_modes_are_each_models_own_and_checked(cd1_space, asb_superelement):
    """A ``StuckModeCache`` handed to several models' calls solves each distinct stuck joint once and gives each
    call the results it would form alone, bit for bit; one made for another structure (any other JointSpace
    object), or with the compliance on other joint rows, is refused."""
    designs = random_designs("iwan4", 30, 3, np.random.default_rng(4))
    jenkins = designs[:, [0, 1, 4, 5, 6, 9, 10, 11, 14]]  # F_S, K_T, K_z of each group: the same stuck joint
    stuck = StuckModeCache(cd1_space, rows=tangential_rows(cd1_space.superelement.n_patches))
    for model, model_designs in (("iwan4", designs), ("jenkins", jenkins)):
        shared = qsma_designs(cd1_space, model, model_designs, amplitudes=AMPLITUDES, stuck=stuck)
        alone = qsma_designs(cd1_space, model, model_designs, amplitudes=AMPLITUDES)
        for name in ("frequency", "damping", "stuck_frequency", "mac", "converged"):
            np.testing.assert_array_equal(getattr(shared, name), getattr(alone, name))
    assert len(stuck) == 1
    with pytest.raises(ValueError, match="another structure"):
        qsma_designs(joint_space(asb_superelement("CD1")), "jenkins", jenkins, amplitudes=AMPLITUDES, stuck=stuck)
    with pytest.raises(ValueError, match="other rows"):
        qsma_designs(cd1_space, "jenkins", jenkins, amplitudes=AMPLITUDES, stuck=StuckModeCache(cd1_space))
