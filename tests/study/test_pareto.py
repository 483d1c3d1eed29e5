"""Pareto fronts (paper Fig. 6): the sort-and-sweep front equals the definition, and NSGA-II reaches a known
front, never returns a design a seed dominates, and repeats itself with the same seed."""

import numpy as np
import pytest

from study.pareto import FAILURE_PENALTY, non_dominated, nsga2_front


def brute_force_front(errors):
    """Definition, O(n^2): a row with no NaN is on the front when no row is <= in both and < in one."""
    valid = ~np.isnan(errors).any(axis=1)
    no_worse = np.all(errors[None, :, :] <= errors[:, None, :], axis=2)  # [i, j]: j no worse than i
    better = np.any(errors[None, :, :] < errors[:, None, :], axis=2)
    dominated = np.any(no_worse & better & valid[None, :], axis=1)
    return valid & ~dominated


@pytest.mark.parametrize("seed", range(5))
def test_sweep_equals_the_definition_with_ties_and_nans(seed):
    rng = np.random.default_rng(seed)
    errors = rng.integers(0, 12, (400, 2)).astype(float)  # few distinct values: many ties and duplicates
    errors[rng.random(400) < 0.1, rng.integers(0, 2)] = np.nan
    np.testing.assert_array_equal(non_dominated(errors), brute_force_front(errors))
    continuous = rng.lognormal(size=(400, 2))
    np.testing.assert_array_equal(non_dominated(continuous), brute_force_front(continuous))


def test_ties():
    errors = np.array([[1.0, 2.0], [1.0, 2.0], [1.0, 3.0], [2.0, 1.0], [3.0, 1.0], [0.5, np.nan]])
    # duplicates both on the front; equal in one error and worse in the other: dominated; NaN: never
    np.testing.assert_array_equal(non_dominated(errors), [True, True, False, True, False, False])
    assert not non_dominated(np.full((3, 2), np.nan)).any()
    assert non_dominated(np.empty((0, 2))).shape == (0,)


def zdt1(designs):
    """ZDT1 (Zitzler, Deb, Thiele 2000): front e_2 = 1 - sqrt(e_1), e_1 in [0, 1], where x_2.. x_d = 0."""
    g = 1 + 9 * designs[:, 1:].mean(axis=1)
    return np.column_stack([designs[:, 0], g * (1 - np.sqrt(designs[:, 0] / g))])


def test_nsga2_reaches_the_known_front():
    rng = np.random.default_rng(0)
    front = nsga2_front(zdt1, rng.random((10, 3)), generations=80, population=40, seed=1)
    gap = front.errors[:, 1] - (1 - np.sqrt(front.errors[:, 0]))  # >= 0 for any design
    assert gap.min() > -1e-12
    assert np.median(gap) < 1e-3 and np.percentile(gap, 90) < 1e-2
    assert front.errors[0, 0] < 0.01 and front.errors[-1, 0] > 0.99  # the whole front, sorted by e_1
    assert np.all(np.diff(front.errors[:, 0]) >= 0)
    np.testing.assert_array_equal(non_dominated(front.errors), True)


def test_failed_designs_never_reach_the_front():
    def failing_beyond_half(designs):
        errors = zdt1(designs)
        errors[designs[:, 0] > 0.5] = np.nan  # QSMA "did not converge" there
        return errors

    rng = np.random.default_rng(2)
    front = nsga2_front(failing_beyond_half, rng.random((20, 3)), generations=30, population=30, seed=3)
    assert len(front.designs) > 0 and not np.isnan(front.errors).any()
    assert np.all(front.designs[:, 0] <= 0.5) and np.all(front.errors < FAILURE_PENALTY)


def test_no_seed_dominates_the_nsga2_front_and_the_same_seed_repeats():
    rng = np.random.default_rng(4)
    sample = rng.random((300, 3))
    sample_errors = zdt1(sample)
    sample_front = sample_errors[non_dominated(sample_errors)]
    initial = np.vstack([sample[non_dominated(sample_errors)], sample[rng.choice(300, 10, replace=False)]])
    front = nsga2_front(zdt1, initial, generations=10, population=30, seed=5)
    no_worse = np.all(sample_front[:, None, :] <= front.errors[None, :, :], axis=2)
    better = np.any(sample_front[:, None, :] < front.errors[None, :, :], axis=2)
    assert not np.any(no_worse & better)
    improved = np.any(np.all(front.errors[:, None, :] <= sample_front[None, :, :], axis=2)
                      & np.any(front.errors[:, None, :] < sample_front[None, :, :], axis=2), axis=0)
    assert improved.any()  # and NSGA-II moved past some of the sample's front
    again = nsga2_front(zdt1, initial, generations=10, population=30, seed=5)
    np.testing.assert_array_equal(again.designs, front.designs)
    np.testing.assert_array_equal(again.errors, front.errors)
    assert front.evaluations == again.evaluations
