"""The loop's candidate answers restarted from Iwan's shapes, on the measured ASB C3 backbone (the shared data,
skipped where absent), with the nominal estimated from it as ``surrogacy discrepancy`` does:

- the model the loop answers for C3 (a second slip stage with microslip, a linear damping and a stiffness change),
  fitted from the loop's own starts (every one with the library's chi -0.5, beta 0.1), ends with beta held at
  Iwan's limit 0; restarted from the shapes of ``SHAPES`` at that optimum, it reaches a lower free optimum whose
  likelihood ratio against the held one exceeds ``LIMIT_TEST``: beta is not at its limit there;
- the loop's answer is that optimum: no restart from a finer grid of shapes that ``SHAPES`` does not hold lowers
  its BIC by more than ``SETTLED``, and the effects it names are the same.
"""

from itertools import product

import pytest

from discrepancy.loop import LIMIT_TEST, SETTLED, SHAPES, base_starts, fit, shape_starts, with_stage_starts
from discrepancy.workflow import measured_input
from locations import ASB_BACKBONES
from study.structures import N_LEVELS

C3 = ASB_BACKBONES / "ASB_C3_20Nm_BB.mat"
EFFECTS = ("second_slip_stage", "microslip", "linear_damping", "stiffness_change")
FINER = tuple(product((-0.1, -0.35, -0.65, -0.9), (2e-3, 5e-3, 0.05, 0.5, 2.0, 5.0)))  # none of them in SHAPES

pytestmark = pytest.mark.skipif(not C3.is_file(), reason=f"{C3} not found (the ASB's measured backbones)")


@pytest.fixture(scope="module")
def c3():
    """The loop's input for the measured C3: (measurement, nominal frequency Hz, nominal damping, their errors)."""
    loop = measured_input(C3, N_LEVELS, None, None).loop
    return (*loop.args, loop.keywords["nominal_uncertainty"])


def test_a_shape_restart_frees_beta_that_the_loops_starts_held_at_its_limit(c3):
    measurement, frequency, damping, uncertainty = c3
    first = fit(measurement, EFFECTS, frequency, damping,
                with_stage_starts(base_starts(measurement, frequency), measurement, frequency), uncertainty)
    assert "beta" in first.held
    restarted = fit(measurement, EFFECTS, frequency, damping, shape_starts(first.parameters), uncertainty)
    assert not restarted.held and not restarted.undetermined
    assert first.chi_squared - restarted.chi_squared > LIMIT_TEST
    assert restarted.parameters["beta"] > 0.1 and restarted.bic < first.bic
    assert not set(FINER) & set(SHAPES)


@pytest.mark.slow  # the loop on C3, about 40 s
def test_the_loops_answer_is_not_lowered_by_finer_shapes(c3):
    from discrepancy.loop import discrepancy_loop

    measurement, frequency, damping, uncertainty = c3
    verdict = discrepancy_loop(measurement, frequency, damping, nominal_uncertainty=uncertainty)
    final = verdict.final
    assert sorted(final.effects) == sorted(EFFECTS) and not final.held
    for chi, beta in FINER:
        again = fit(measurement, final.effects, frequency, damping, [{**final.parameters, "chi": chi, "beta": beta}],
                    uncertainty)
        assert again.bic > final.bic - SETTLED, (chi, beta, again.bic, final.bic)
