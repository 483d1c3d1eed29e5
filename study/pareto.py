"""Pareto fronts of the two L-infinity errors (paper section 4.4, Fig. 6): of a sample, and by NSGA-II.

Both objectives are minimised: e_f (Hz) and e_zeta (-). A design dominates another when it is no worse in both
errors and better in at least one; the front is the set of designs no other design dominates. A design whose
errors are NaN (QSMA did not converge) is never on a front.

``non_dominated`` is a sort-and-sweep for two objectives, O(n log n), for samples of millions of designs
(pymoo's non-dominated sorting compares all pairs, O(n^2)). ``nsga2_front`` runs pymoo's NSGA-II (Deb et al.
2002, the paper's ref. [16]) on designs in a box (the unit cube of the caller's parameter map), seeded with
designs of the sample, and returns the non-dominated set of every design it evaluated, seeds included: elitism
by archive, so no returned design is dominated by a seed, even where NSGA-II's crowding truncation dropped it.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.core.problem import Problem
from pymoo.optimize import minimize

FAILURE_PENALTY = 1e12
"""Both errors NSGA-II sees for a failed (NaN) design: finite, so that the sorting works, and above any physical
error (Hz or -), so that every converged design dominates it and selection discards it."""


def non_dominated(errors) -> np.ndarray:
    """Mask of the non-dominated rows of errors (n, 2), both minimised; rows with a NaN are never on the front.

    Sort by (e_1, e_2) and sweep: a row is dominated when a row with smaller e_1 has e_2 no larger (running
    minimum over the earlier e_1 groups), or when a row with the same e_1 has smaller e_2 (the group's first row).
    Equal rows are all non-dominated; a row equal in one error and worse in the other is dominated. O(n log n).
    Returns (n,) bool.
    """
    errors = np.asarray(errors, dtype=float)
    front = np.zeros(errors.shape[0], dtype=bool)
    valid = np.flatnonzero(~np.isnan(errors).any(axis=1))
    first, second = errors[valid, 0], errors[valid, 1]
    order = np.lexsort((second, first))
    first, second = first[order], second[order]
    group_start = np.searchsorted(first, first, side="left")
    running_minimum = np.minimum.accumulate(second)
    best_before_group = np.where(group_start > 0, running_minimum[np.maximum(group_start - 1, 0)], np.inf)
    front[valid[order]] = (second == second[group_start]) & (second < best_before_group)
    return front


class ParetoDesigns(NamedTuple):
    """Non-dominated designs: designs (m, d) in the optimiser's box; errors (m, 2) (e_f Hz, e_zeta -), sorted by
    increasing first error; evaluations: number of distinct designs evaluated (seeds included); generations: the
    NSGA-II generations run, the initial one included."""

    designs: np.ndarray
    errors: np.ndarray
    evaluations: int
    generations: int


class _PenalisedErrors(Problem):
    """pymoo problem over a population: the caller's errors with NaN rows replaced by ``FAILURE_PENALTY``;
    every design evaluated and its (unpenalised) errors are archived."""

    def __init__(self, objective, lower, upper):
        super().__init__(n_var=lower.size, n_obj=2, xl=lower, xu=upper)
        self.objective = objective
        self.archive: list[tuple[np.ndarray, np.ndarray]] = []

    def _evaluate(self, designs, out, *args, **kwargs):
        errors = np.asarray(self.objective(designs), dtype=float).reshape(len(designs), 2)
        self.archive.append((np.array(designs, dtype=float), errors))
        out["F"] = np.where(np.isnan(errors).any(axis=1, keepdims=True), FAILURE_PENALTY, errors)


def nsga2_front(objective: Callable[[np.ndarray], np.ndarray], initial, *, lower=0.0, upper=1.0,
                generations: int = 100, population: int = 100, seed: int = 0, termination=None) -> ParetoDesigns:
    """Pareto front of objective by NSGA-II (pymoo), seeded with designs of a sample (paper Fig. 6).

    objective: (m, d) designs -> (m, 2) errors (e_f Hz, e_zeta -), NaN rows for failed designs (NSGA-II sees
    ``FAILURE_PENALTY`` for them, so selection discards them); evaluated a population at a time.
    initial: (k, d) designs seeding the first population (e.g. the sample's front and random sample members);
    when k < population the rest is drawn uniformly in the box; when k > population all are evaluated and
    NSGA-II's survival keeps ``population`` of them. lower, upper: (d,) or scalar bounds of the box
    (the unit cube by default; the caller maps it to physical parameters). generations: number of NSGA-II
    generations including the initial one; population: its size; seed: of pymoo's random generator (same seed,
    same result). termination: a pymoo termination criterion in place of the fixed ``generations`` (e.g.
    ``DefaultMultiObjectiveTermination``, which stops when the front no longer moves).

    Returns the non-dominated designs of everything evaluated (seeds included), so that no returned design is
    dominated by a seed.
    """
    initial = np.atleast_2d(np.asarray(initial, dtype=float))
    lower = np.broadcast_to(np.asarray(lower, dtype=float), initial.shape[1:]).copy()
    upper = np.broadcast_to(np.asarray(upper, dtype=float), initial.shape[1:]).copy()
    fill = np.random.default_rng(seed).uniform(lower, upper, (max(population - len(initial), 0), lower.size))
    problem = _PenalisedErrors(objective, lower, upper)
    algorithm = NSGA2(pop_size=population, sampling=np.vstack([initial, fill]))
    result = minimize(problem, algorithm, termination=termination or ("n_gen", generations), seed=seed)
    designs, evaluated = np.unique(np.vstack([designs for designs, _ in problem.archive]), axis=0,
                                   return_index=True)
    errors = np.vstack([errors for _, errors in problem.archive])[evaluated]
    front = np.flatnonzero(non_dominated(errors))
    front = front[np.lexsort((errors[front, 1], errors[front, 0]))]
    return ParetoDesigns(designs[front], errors[front], len(designs), int(result.algorithm.n_gen))
