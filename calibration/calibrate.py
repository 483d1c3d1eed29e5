"""A calibration of one friction model on one structure: a global multi-objective search, then least-squares
polishes along its front, then the best compromise with its uncertainty (docs/design.md section 11).

Global phase. NSGA-II (``study.pareto.nsga2_front``) over the unit box of ``calibration.objectives`` (the joint's
Table 3 parameters and zeta_0) on the two L-infinity errors, seeded with the designs a study found (its sample's
and its NSGA-II front, zeta_0 at the study's value and spread over its range) and run until the front stops
moving: pymoo's ``DefaultMultiObjectiveTermination`` (its default tolerances: the ideal, nadir and front move
by less than 0.25 % over 30 generations), at most ``MAX_GENERATIONS`` (a run that reaches the cap says so).

Local phase. For each weight of ``WEIGHTS`` between frequency (w -> 1) and damping (w -> 0), the ``STARTS`` points
of the global front and the seeds with the lowest weighted chi^2 are polished by ``calibration.local_fit.local_fit``
(the chi^2 optimum need not lie near the L-infinity front); a model that contains another (iwan5 and iwan4_core
contain iwan4) is also polished from that model's calibrated optimum of lowest weighted chi^2, so the larger model
fits at least as well. These are extra starts only: the global search keeps its own seeds, whose basins can be
better (on ASB CD1 the stuck core's best, chi^2 162.6, is not near the contained iwan4's optimum, 208.8).

Result. The calibrated front is the non-dominated set, in the two L-infinity errors, of the global front and every
polished point. The best compromise is the polished point of w = 1/2 (the plain chi^2 of frequency and damping)
with the lowest chi^2, with its plain errors and its parameters' uncertainty; besides its own starts, w = 1/2 is
polished from the best optimum of every other weight (on the measured ASB these reach lower chi^2 than the
front's points: C1 iwan4 77 against 144, C3 132 against 189, CD1 209 against 238).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from pymoo.termination.default import DefaultMultiObjectiveTermination

from calibration.local_fit import LocalFit, Uncertainty, local_fit, residual_rows, uncertainty
from calibration.objectives import FitSpace, fit_space, linf_errors, model_curves, plain_errors, unit_zeta0
from nonlinear.condensation import modal_split
from study.pareto import non_dominated, nsga2_front
from study.structures import Structure

WEIGHTS = (0.1, 0.3, 0.5, 0.7, 0.9)
"""Weights w of the frequency residuals in the local phase (1 - w for damping)."""
STARTS = 3
"""Points (of the global front and the seeds) each weight is polished from."""
POPULATION = 64
MAX_GENERATIONS = 800
ZETA0_SEEDS = 4
"""Values of zeta_0 (spread over its unit range) each seed design is paired with, besides the study's."""


class Calibration(NamedTuple):
    """One friction model calibrated on one structure.

    space: the box. front_unit (k, d + 1), front_errors (k, 2) (e_f Hz, e_zeta -): the calibrated front, sorted by
    e_f, and front_source (k,): "global" or "polished w=<w>". fits: every local fit. best: the best compromise,
    best_errors its plain errors (``calibration.objectives.plain_errors``), best_uncertainty its parameters'.
    global_evaluations, global_generations: the global phase's cost.
    """

    structure: str
    space: FitSpace
    front_unit: np.ndarray
    front_errors: np.ndarray
    front_source: tuple[str, ...]
    fits: tuple[LocalFit, ...]
    best: LocalFit
    best_errors: dict
    best_uncertainty: Uncertainty
    global_evaluations: int
    global_generations: int


def seed_points(space: FitSpace, designs_unit, study_zeta0: float, rng: np.random.Generator) -> np.ndarray:
    """Unit seeds (n (1 + ZETA0_SEEDS), d + 1): each study design with the study's zeta_0 and with ZETA0_SEEDS
    values drawn over zeta_0's range."""
    designs_unit = np.atleast_2d(designs_unit)
    zeta0 = np.column_stack([np.full(len(designs_unit), unit_zeta0(space, study_zeta0)),
                             rng.random((len(designs_unit), ZETA0_SEEDS))])
    return np.column_stack([np.repeat(designs_unit, zeta0.shape[1], axis=0), zeta0.ravel()])


def calibrate(structure: Structure, model: str, n_groups: int, seeds_unit, study_zeta0: float, seed: int = 0,
              max_generations: int = MAX_GENERATIONS, fitted_seeds=None) -> Calibration:
    """Calibrate ``model`` on ``structure`` (module docstring). seeds_unit: (n, d) the study's designs in Table 3
    unit coordinates; study_zeta0: the study's linear damping for the structure; seed: NSGA-II's random seed
    (the same seed gives the same calibration); max_generations: the global phase's cap; fitted_seeds: (k, d + 1)
    points of the fit's box (design and zeta_0), e.g. the calibrated front of the model this one contains: each
    weight is also polished from the one of lowest chi^2, so that the larger model fits at least as well."""
    space = fit_space(model, n_groups, structure.measurement)
    split = modal_split(structure.space)
    measurement = structure.measurement

    def objective(unit):
        return linf_errors(measurement, model_curves(structure, space, unit, split))

    seeds = seed_points(space, seeds_unit, study_zeta0, np.random.default_rng(seed))
    fitted_seeds = np.empty((0, len(space.names))) if fitted_seeds is None else np.atleast_2d(fitted_seeds)
    termination = DefaultMultiObjectiveTermination(n_max_gen=max_generations)
    found = nsga2_front(objective, seeds, population=POPULATION, seed=seed, termination=termination)
    fits = []
    starts = np.vstack([found.designs, seeds])
    for weight in WEIGHTS:
        chi_squared = np.sum(residual_rows(structure, space, starts, weight, split) ** 2, axis=1)
        fits += [local_fit(structure, space, starts[start], weight, split)
                 for start in np.argsort(chi_squared)[:STARTS]]
        if len(fitted_seeds):  # besides the search's own starts, not instead of them
            fitted_chi_squared = np.sum(residual_rows(structure, space, fitted_seeds, weight, split) ** 2, axis=1)
            fits.append(local_fit(structure, space, fitted_seeds[np.argmin(fitted_chi_squared)], weight, split))
    fits += [local_fit(structure, space, min((fit for fit in fits if fit.weight == weight),
                                             key=lambda fit: fit.chi_squared).unit, 0.5, split)
             for weight in WEIGHTS if weight != 0.5]  # the sweep's other optima as starts of the best compromise
    polished = np.array([fit.unit for fit in fits])
    candidates = np.vstack([found.designs, polished])
    errors = np.vstack([found.errors, objective(polished)])
    sources = ["global"] * len(found.designs) + [f"polished w={fit.weight:g}" for fit in fits]
    front = np.flatnonzero(non_dominated(errors))
    front = front[np.lexsort((errors[front, 1], errors[front, 0]))]
    best = min((fit for fit in fits if fit.weight == 0.5), key=lambda fit: fit.chi_squared)
    best_curves = model_curves(structure, space, best.unit[None, :], split)
    return Calibration(structure.name, space, candidates[front], errors[front], tuple(sources[i] for i in front),
                       tuple(fits), best, plain_errors(measurement, best_curves),
                       uncertainty(structure, space, best.unit, split), found.evaluations, found.generations)
