"""A calibration of one friction model on one structure: a global multi-objective search, then least-squares
polishes along its front, a deterministic multistart, then the best compromise with its uncertainty
(docs/design.md section 11).

Global phase. NSGA-II (``study.pareto.nsga2_front``) over the unit box of ``calibration.objectives`` (the joint's
Table 3 parameters and zeta_0) on the two L-infinity errors, seeded with the designs a study found (its sample's
and its NSGA-II front, zeta_0 at the study's value, at the value its damping rule gave each design, and spread over
its range) and run until the front stops
moving: pymoo's ``DefaultMultiObjectiveTermination`` (its default tolerances: the ideal, nadir and front move
by less than 0.25 % over 30 generations), at most ``MAX_GENERATIONS`` (a run that reaches the cap says so).

Local phase. For each weight of ``WEIGHTS`` between frequency (w -> 1) and damping (w -> 0), the ``STARTS`` points
of the global front and the seeds with the lowest weighted chi^2 are polished by ``calibration.local_fit.local_fit``
(the chi^2 optimum need not lie near the L-infinity front); a model that contains another
(``FrictionModel.contains``) is also polished from that model's calibrated optimum of lowest weighted chi^2, so the
larger model fits at least as well.

Multistart. The global phase follows the study's sample, and a sample of another seed reaches other basins (on the
measured ASB the best compromise's chi^2 moved by up to 28 % between two study seeds). So that the best compromise
does not depend on the sample, w = 1/2 is also polished from ``MULTISTARTS`` points of a fixed (unscrambled) Sobol
sequence of ``MULTISTART_POINTS`` points over the whole box: those of lowest chi^2; and from the ``MULTISTARTS`` of
lowest chi^2 of an anchored screen: ``ANCHORED_POINTS`` Sobol points of the joint's coordinates, each coordinate at
its lower and at its upper limit for a share ``PIN`` of them each (optima sit on Table 3's limits, alone or several
at once: iwan4_core on the measured ASB C2 has its optimum at a corner, F_S at its floor, K_T, chi and beta at their
ceilings), moved onto the measured stuck frequency with zeta_0 at its least-squares value (``anchored_points``, see
Escape): where the frequency residuals, whose uncertainty is 1e-4 of the frequency, dominate chi^2, a plain screen
ranks its points by how near their stuck frequency happens to be, not by what the joint does. Each polished point is
then scanned along each coordinate over its whole unit range (``SCAN_POINTS`` values, all coordinates in one QSMA
call) and polished again from the best point of the scans while that lowers chi^2 by more than ``SCAN_GAIN``
(relative), at most ``SCAN_SWEEPS`` times: a friction model's chi^2 is flat in a parameter that does not act (F_S of
a joint that never slips at the measured levels), where a gradient method stays.

Escape. A Jenkins joint's backbone has a kink where each measured level starts to slip, and the chi^2 a local
minimum at each kink: on the measured ASB C4a, fits stopped at reduced chi^2 23.1 (no level slips) and 17.3 (the
top one slips) where 15.1 (the top two) lies 0.003 away in the unit box, along the thin valley of stiffnesses that
keep the measured stuck frequency; neither coordinate scans nor a screen of the whole box finds it. So the best
compromise is also compared with clouds of ``CLOUD_POINTS`` points (the unscrambled Sobol sequence) within each of
``CLOUD_RADII`` of it in the joint's unit coordinates, each point moved onto that valley (``anchored_points``: its
stiffnesses scaled by one factor so that the frequency at the lowest measured level is the measured one, zeta_0
at its least-squares value); a cloud point of lower chi^2 is polished and scanned, and replaces the best
compromise where it stays lower, at most ``ESCAPES`` times.

Result. The calibrated front is the non-dominated set, in the two L-infinity errors, of every point the
calibration evaluated (``calibration.objectives.FrontArchive``: the global phase's, every local fit's and the
multistart's). The best compromise is the w = 1/2 fit (the plain chi^2 of frequency and damping) of lowest chi^2
among its own starts, the multistart's, the contained model's and the best optimum of every other weight, scanned
and polished as a multistart point, and continued from where its evaluation budget stopped it up to
``CONTINUATIONS`` times: it is reported as converged only where its last run stopped on its tolerances. It comes
with its plain errors and its parameters' uncertainty.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from pymoo.termination.default import DefaultMultiObjectiveTermination
from scipy.stats import qmc

from calibration.local_fit import LocalFit, Uncertainty, local_fit, residual_rows, uncertainty
from calibration.objectives import (BackboneSolver, FitSpace, FrontArchive, backbone_solver, fit_space, linf_errors,
                                   model_curves, physical, plain_errors, profiled_zeta0, unit_zeta0)
from nonlinear.friction_models import STIFFNESS_PARAMETERS
from nonlinear.joint import to_unit
from nonlinear.qsma_vectorised import qsma_designs
from study.errors import structure_damping
from study.pareto import nsga2_front
from study.structures import Structure

WEIGHTS = (0.1, 0.3, 0.5, 0.7, 0.9)
"""Weights w of the frequency residuals in the local phase (1 - w for damping)."""
STARTS = 3
"""Points (of the global front and the seeds) each weight is polished from."""
POPULATION = 64
MAX_GENERATIONS = 800
ZETA0_SEEDS = 4
"""Values of zeta_0 (spread over its unit range) each seed design is paired with, besides the study's."""
MULTISTART_POINTS = 4096
"""Points of the Sobol sequence over the unit box whose chi^2 the multistart ranks (a power of two)."""
MULTISTARTS = 8
"""Points of lowest chi^2 among them (and among the anchored screen's) that w = 1/2 is polished from."""
ANCHORED_POINTS = 16384
"""Points of the anchored screen (a power of two)."""
PIN = 0.2
"""Share of the anchored screen's values of each coordinate at each of its two limits."""
SCAN_POINTS = 33
"""Values of each coordinate, evenly over its unit range, of one scan."""
SCAN_SWEEPS = 6
SCAN_GAIN = 1e-6
"""Relative fall of chi^2 a scan must find to be polished from."""
CONTINUATIONS = 9
"""Restarts of the best compromise's fit from where its evaluation budget (400 each) stopped it."""
CLOUD_POINTS = 256
"""Points of one cloud around the best compromise (a power of two)."""
CLOUD_RADII = (0.1, 0.03, 0.01)
"""Half-widths of the clouds in unit coordinates, widest first."""
ESCAPES = 6
"""Moves of the best compromise to a cloud's lower basin."""
ANCHOR_ITERATIONS = 10
"""Most secant steps on the stiffness factor's logarithm."""
METHOD = {"weights": WEIGHTS, "starts": STARTS, "population": POPULATION, "zeta0_seeds": ZETA0_SEEDS,
          "multistart_points": MULTISTART_POINTS, "multistarts": MULTISTARTS,
          "anchored_points": ANCHORED_POINTS, "pin": PIN, "scan_points": SCAN_POINTS,
          "scan_sweeps": SCAN_SWEEPS, "scan_gain": SCAN_GAIN, "continuations": CONTINUATIONS,
          "cloud_points": CLOUD_POINTS, "cloud_radii": CLOUD_RADII, "escapes": ESCAPES,
          "seeds_at_the_rule_s_zeta0": True}
"""The settings a calibration's result depends on besides its inputs (part of a record's key)."""


class Calibration(NamedTuple):
    """One friction model calibrated on one structure.

    space: the box. front_unit (k, d + 1), front_errors (k, 2) (e_f Hz, e_zeta -): the calibrated front, sorted by
    e_f, and front_source (k,): the phase that evaluated each point ("global", "polished w=<w>", "multistart" or
    "best compromise"). fits: every local fit. best: the best compromise,
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


def seed_points(space: FitSpace, designs_unit, study_zeta0: float, rng: np.random.Generator, rule_zeta0=None
                ) -> np.ndarray:
    """Unit seeds (n (1 + ZETA0_SEEDS (+ 1)), d + 1): each study design with the study's zeta_0, with ZETA0_SEEDS
    values drawn over zeta_0's range and, where ``rule_zeta0`` (n,) is given, with the zeta_0 the study's damping
    rule gives that design (``rule_zeta0``): the study's own evaluation of it, so that the calibrated front weakly
    dominates the study's (to zeta_0's floor, 1e-6, where the rule gives 0)."""
    designs_unit = np.atleast_2d(designs_unit)
    columns = [np.full(len(designs_unit), unit_zeta0(space, study_zeta0)),
               rng.random((len(designs_unit), ZETA0_SEEDS))]
    if rule_zeta0 is not None:
        columns.append(unit_zeta0(space, np.asarray(rule_zeta0, dtype=float)))
    zeta0 = np.column_stack(columns)
    return np.column_stack([np.repeat(designs_unit, zeta0.shape[1], axis=0), zeta0.ravel()])


def rule_zeta0(structure: Structure, space: FitSpace, designs_unit, study_zeta0: float, rule: str,
               solver: BackboneSolver) -> np.ndarray:
    """zeta_0 (n,) that the study's damping rule (``study.errors.structure_damping``) gives each of its designs
    (n, d unit) on ``structure`` from the case's value ``study_zeta0``: the joint's own damping at the lowest
    level comes from QSMA (zeta_0 at its floor, taken off again); the case's value where QSMA does not converge."""
    designs_unit = np.atleast_2d(designs_unit)
    curves = model_curves(structure, space, np.column_stack([designs_unit, np.zeros(len(designs_unit))]), solver)
    zeta0 = structure_damping(curves.damping - space.lower[-1], [study_zeta0], rule)[:, 0]
    return np.where(np.isfinite(zeta0), zeta0, study_zeta0)


def chi_squared(structure: Structure, space: FitSpace, unit, solver: BackboneSolver, archive: FrontArchive | None = None
                ) -> np.ndarray:
    """The plain chi^2 (w = 1/2) of unit points (n, d + 1): (n,)."""
    return np.sum(residual_rows(structure, space, unit, 0.5, solver, archive) ** 2, axis=1)


def coordinate_scans(point: np.ndarray) -> np.ndarray:
    """Points ((d + 1) SCAN_POINTS, d + 1): ``point`` (d + 1,) with each coordinate in turn at SCAN_POINTS values
    evenly over [0, 1]."""
    values = np.linspace(0.0, 1.0, SCAN_POINTS)
    points = np.repeat(point[None, :], point.size * SCAN_POINTS, axis=0)
    points[np.arange(points.shape[0]), np.repeat(np.arange(point.size), SCAN_POINTS)] = np.tile(values, point.size)
    return points


def scanned(structure: Structure, space: FitSpace, fit: LocalFit, solver: BackboneSolver, archive: FrontArchive,
            continuations: int = 0) -> LocalFit:
    """``fit`` (w = 1/2) polished again from the best point of its coordinate scans while they lower its chi^2 by
    more than SCAN_GAIN, at most SCAN_SWEEPS times (module docstring); each fit restarted up to ``continuations``
    times where its budget stops it."""
    for _ in range(SCAN_SWEEPS):
        points = coordinate_scans(fit.unit)
        values = chi_squared(structure, space, points, solver, archive)
        best = int(np.argmin(values))
        if not values[best] < fit.chi_squared * (1.0 - SCAN_GAIN):
            break
        fit = local_fit(structure, space, points[best], 0.5, solver, continuations=continuations, archive=archive)
    return fit


def anchored_points(structure: Structure, space: FitSpace, joint_unit, solver: BackboneSolver
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Unit joint points (n, d) moved onto the measured stuck frequency (module docstring, Escape): each point's
    stiffnesses (``STIFFNESS_PARAMETERS``, N/m) times one factor s, found by the secant method on ln s (at most
    ``ANCHOR_ITERATIONS`` steps, the points still off at once, s kept where every stiffness stays within its limits)
    so that QSMA's frequency at the lowest measured level equals the measured one within its standard uncertainty;
    zeta_0 at its least-squares value (``calibration.objectives.profiled_zeta0``). Returns the points anchored
    within the limits, unit (m, d + 1), and their plain chi^2 (m,)."""
    measurement = structure.measurement
    designs, _ = physical(space, np.column_stack([joint_unit, np.zeros(len(joint_unit))]))
    stiffness = np.array([name.split("[")[0] in STIFFNESS_PARAMETERS for name in space.names[:-1]])

    def frequency_error(log_factor, rows):
        scaled = designs[rows]
        scaled[:, stiffness] *= np.exp(log_factor)[:, None]
        result = qsma_designs(structure.space, space.model, scaled, amplitudes=measurement.amplitude[:1],
                              linear_damping=0.0, split=solver.split, device=solver.device)
        return result.frequency[:, 0] / (2.0 * np.pi) - measurement.frequency_hz[0]

    # the factors that keep every stiffness within its Table 3 limits
    smallest = np.max(np.log(space.lower[:-1][stiffness] / designs[:, stiffness]), axis=1)
    largest = np.min(np.log(space.upper[:-1][stiffness] / designs[:, stiffness]), axis=1)
    every = np.arange(len(designs))
    previous, current = np.zeros(len(designs)), np.clip(0.1, smallest, largest)
    previous_error, error = frequency_error(previous, every), frequency_error(current, every)
    tolerance = measurement.sigma_frequency[0]
    for _ in range(ANCHOR_ITERATIONS):  # only the points still off by more than the tolerance, and moving
        active = np.flatnonzero((np.abs(error) > tolerance) & (current != previous))
        if not active.size:
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            following = current[active] - error[active] * (current[active] - previous[active]) / (
                error[active] - previous_error[active])
        following = np.clip(np.where(np.isfinite(following), following, current[active]), smallest[active],
                            largest[active])
        previous[active], previous_error[active] = current[active], error[active]
        current[active] = following
        error[active] = frequency_error(following, active)
    held = np.abs(error) <= tolerance
    scaled = designs[held]
    scaled[:, stiffness] *= np.exp(current[held])[:, None]
    joint = to_unit(scaled, space.lower[:-1], space.upper[:-1], space.logarithmic[:-1])
    curves = model_curves(structure, space, np.column_stack([joint, np.zeros(len(joint))]), solver)
    joint_damping = curves.damping - space.lower[-1]
    zeta0 = profiled_zeta0(space, measurement, joint_damping)
    chi_squared_values = (np.sum(((curves.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2,
                                 axis=1)
                          + np.sum(((joint_damping + zeta0[:, None] - measurement.damping)
                                    / measurement.sigma_damping) ** 2, axis=1))
    return (np.column_stack([joint, unit_zeta0(space, zeta0)]),
            np.where(curves.converged, chi_squared_values, np.inf))


def pinned_screen(n_points: int, dimension: int) -> np.ndarray:
    """The first ``n_points`` of the unscrambled Sobol sequence in ``dimension`` unit coordinates, each mapped by
    u -> clip((u - PIN) / (1 - 2 PIN), 0, 1): a share PIN of each coordinate's values at 0, as many at 1, the rest
    spread evenly between (n_points, dimension)."""
    points = qmc.Sobol(dimension, scramble=False).random(n_points)
    return np.clip((points - PIN) / (1.0 - 2.0 * PIN), 0.0, 1.0)


def multistart(structure: Structure, space: FitSpace, solver: BackboneSolver, archive: FrontArchive) -> list[LocalFit]:
    """The multistart's w = 1/2 fits (module docstring): from the MULTISTARTS points of lowest chi^2 among the
    first MULTISTART_POINTS of the unscrambled Sobol sequence over the unit box and from the MULTISTARTS of the
    anchored screen, each scanned."""
    points = qmc.Sobol(len(space.names), scramble=False).random(MULTISTART_POINTS)
    values = chi_squared(structure, space, points, solver, archive)
    anchored, anchored_values = anchored_points(structure, space, pinned_screen(ANCHORED_POINTS, len(space.names) - 1),
                                                solver)
    starts = [*points[np.argsort(values)[:MULTISTARTS]], *anchored[np.argsort(anchored_values)[:MULTISTARTS]]]
    return [scanned(structure, space, local_fit(structure, space, start, 0.5, solver, archive=archive), solver, archive)
            for start in starts]


def escaped(structure: Structure, space: FitSpace, fit: LocalFit, solver: BackboneSolver, archive: FrontArchive
            ) -> LocalFit:
    """``fit`` (w = 1/2) moved to the lower basin of an anchored cloud around it while one is found (module
    docstring, Escape), each new fit polished and scanned with ``CONTINUATIONS``."""
    offsets = 2.0 * qmc.Sobol(len(space.names) - 1, scramble=False).random(CLOUD_POINTS) - 1.0
    for _ in range(ESCAPES):
        for radius in CLOUD_RADII:
            points, values = anchored_points(structure, space, np.clip(fit.unit[:-1] + radius * offsets, 0.0, 1.0),
                                             solver)
            if not (values.size and values.min() < fit.chi_squared * (1.0 - SCAN_GAIN)):
                continue
            candidate = scanned(structure, space, local_fit(structure, space, points[np.argmin(values)], 0.5, solver,
                                                            continuations=CONTINUATIONS, archive=archive),
                                solver, archive, CONTINUATIONS)
            if candidate.chi_squared < fit.chi_squared * (1.0 - SCAN_GAIN):
                fit = candidate
                break
        else:
            return fit
    return fit


def calibrate(structure: Structure, model: str, n_groups: int, seeds_unit, study_zeta0: float, seed: int = 0,
              max_generations: int = MAX_GENERATIONS, fitted_seeds=None, damping_rule: str = "added",
              device: str = "cpu") -> Calibration:
    """Calibrate ``model`` on ``structure`` (module docstring). seeds_unit: (n, d) the study's designs in Table 3
    unit coordinates; study_zeta0: the study's linear damping for the structure; seed: NSGA-II's random seed
    (the same seed gives the same calibration); max_generations: the global phase's cap; fitted_seeds: (k, d + 1)
    points of the fit's box (design and zeta_0), e.g. the calibrated front of the model this one contains: each
    weight is also polished from the one of lowest chi^2, so that the larger model fits at least as well;
    damping_rule: the study's (``study.errors.DAMPING_RULES``), by which it gave each design its zeta_0; device:
    where every QSMA call of the calibration is solved (``calibration.objectives.BackboneSolver``)."""
    space = fit_space(model, n_groups, structure.measurement)
    solver = backbone_solver(structure, device)
    measurement = structure.measurement
    archive = FrontArchive(len(space.names))

    def objective(unit):
        return linf_errors(measurement, model_curves(structure, space, unit, solver, archive))

    by_rule = (None if damping_rule == "added"
               else rule_zeta0(structure, space, seeds_unit, study_zeta0, damping_rule, solver))
    seeds = seed_points(space, seeds_unit, study_zeta0, np.random.default_rng(seed), by_rule)
    fitted_seeds = np.empty((0, len(space.names))) if fitted_seeds is None else np.atleast_2d(fitted_seeds)
    termination = DefaultMultiObjectiveTermination(n_max_gen=max_generations)
    archive.source = "global"
    found = nsga2_front(objective, seeds, population=POPULATION, seed=seed, termination=termination)
    fits = []
    starts = np.vstack([found.designs, seeds])
    for weight in WEIGHTS:
        archive.source = f"polished w={weight:g}"
        chi_squared_w = np.sum(residual_rows(structure, space, starts, weight, solver) ** 2, axis=1)
        fits += [local_fit(structure, space, starts[start], weight, solver, archive=archive)
                 for start in np.argsort(chi_squared_w)[:STARTS]]
        if len(fitted_seeds):  # besides the search's own starts, not instead of them
            fitted_chi_squared = np.sum(residual_rows(structure, space, fitted_seeds, weight, solver, archive) ** 2,
                                        axis=1)
            fits.append(local_fit(structure, space, fitted_seeds[np.argmin(fitted_chi_squared)], weight, solver,
                                  archive=archive))
    archive.source = "polished w=0.5"
    fits += [local_fit(structure, space, min((fit for fit in fits if fit.weight == weight),
                                             key=lambda fit: fit.chi_squared).unit, 0.5, solver, archive=archive)
             for weight in WEIGHTS if weight != 0.5]  # the sweep's other optima as starts of the best compromise
    archive.source = "multistart"
    fits += multistart(structure, space, solver, archive)
    archive.source = "best compromise"
    best = min((fit for fit in fits if fit.weight == 0.5), key=lambda fit: fit.chi_squared)
    best = scanned(structure, space, local_fit(structure, space, best.unit, 0.5, solver, continuations=CONTINUATIONS,
                                               archive=archive), solver, archive, CONTINUATIONS)
    best = escaped(structure, space, best, solver, archive)
    fits.append(best)
    best_curves = model_curves(structure, space, best.unit[None, :], solver)
    front_unit, front_errors, front_source = archive.front()
    return Calibration(structure.name, space, front_unit, front_errors, front_source, tuple(fits), best,
                       plain_errors(measurement, best_curves), uncertainty(structure, space, best.unit, solver),
                       found.evaluations, found.generations)
