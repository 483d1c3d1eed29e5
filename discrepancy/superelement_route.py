"""The discrepancy loop on a structure's own model: its superelement and friction model, fitted from fixed
starting points. ``discrepancy.loop`` holds the loop, the effect library and the one-mode model for measurements
with no finite-element model behind them; this module puts the structure's QSMA in the one-mode model's place.

Candidates. The designs a friction model's fits start from are the first ``SCREEN_POINTS`` points of the
unscrambled Sobol sequence over its Table 3 unit box (``screened_candidates``), evaluated by the study's QSMA
(``qsma_designs``) at the measurement's levels with the study's linear damping zeta_0 (borrowed, as the paper did,
made each design's by the study's damping rule, ``study.errors.structure_damping``). They are where the fits start,
not the answer. A study's own Pareto designs are not used: they are a random sample's, and a sample of another
seed reaches other basins (on the measured ASB the loop named other effects on 3 of 6 configurations between two
study seeds); fixed starts give the same fits, effects and verdict whatever the study's seed.

Fit. Every model the loop tries is fitted by weighted least squares
(``calibration.local_fit.continued_least_squares``: trust-region reflective, the Jacobian by central differences
through one vectorised QSMA call, restarted from where its budget of ``MAX_EVALUATIONS`` stopped it up to
``CONTINUATIONS`` times; a fit whose last run still stops on its budget is reported as not converged) over the
friction model's joint parameters in the study's unit box (log where Table 3 samples in log) and the parameters of the
effects outside the joint (the loop's variables, ``discrepancy.loop.TRANSFORMS``), each residual divided by the
measurement's uncertainty. The model's backbone is QSMA's omega_j(q), zeta_j(q) of the joint alone with

    linear_damping     zeta_j(q) + zeta_0'             (zeta_0' free; otherwise the borrowed zeta_0 by the rule)
    stiffness_change   f(q) (1 + s)                     (a linear stiffness or mass change outside the joint;
                                                         the joint's share of the stiffness is kept)
    amplitude_damping  zeta(q) + c q / q_max
    cubic_stiffening   sqrt(f(q)^2 + gamma f(q_min)^2 (q / q_max)^2)

The friction effects change the friction model (microslip = iwan4, microslip with stiction = iwan5, microslip
with a stuck core = iwan4_core: K_c, a spring beside each element that never slips), each counting its model's
parameters in the BIC. The first fit of a friction model starts from its candidates closest
to the measurement in frequency, in damping and in both (``shortlist``, two each); every later fit of it starts
from that optimum, from the closest candidate of each ranking and from the previous step's optimum, with the new
effect at its library start (a fit that absorbed an effect into the joint's parameters can be a poor start for the
model that holds the effect). A friction model that contains another (``FrictionModel.contains``: iwan4 holds
Jenkins, iwan5 and iwan4_core hold iwan4) also starts from the optimum of the contained model with the same
effects outside the joint (its added parameters at ``nonlinear.friction_models.CONTAINED_UNIT``), fitted first: the
larger model is never worse than the one it contains. A model the loop fits again (``select_effects``: from another
model's optimum) starts from that optimum alone, where it is a design of the same friction model.

Reference. The macroslip model (Jenkins) fitted with no effect: what the best Jenkins joint on this superelement
misses. The loop itself (forward selection by BIC, honest-fit rules, stepwise swap and drop, "unexplained") is
``select_effects``.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

from calibration.calibrate import SCAN_GAIN, SCAN_SWEEPS, coordinate_scans
from calibration.local_fit import continued_least_squares
from nonlinear.condensation import JointSpace
from nonlinear.friction_models import FRICTION_MODELS
from nonlinear.joint import contained_unit_designs, from_unit, parameter_limits, parameter_names, to_unit
from nonlinear.qsma_vectorised import qsma_designs
from study.datasets import dataset
from discrepancy.effects import EFFECTS, FRICTION_EFFECTS, OUTSIDE_JOINT
from discrepancy.loop import (UNDEFINED_MISFIT, Fit, Verdict, _to_parameters, _to_vector, bic, determinacy,
                              outside_joint, select_effects, unresolved_effects, weighted_misfit)
from study.errors import structure_damping
from study.pareto import non_dominated
from study.structures import BackboneLevels
from study.workflow import read_study

REFERENCE_MODEL = next(name for name, effects in FRICTION_EFFECTS.items() if not effects)  # macroslip only
SCREEN_POINTS = 16384
"""Points of the unscrambled Sobol sequence over a friction model's unit box its fits' starts are screened from."""
SHORTLIST = 2  # candidates per chi^2 ranking a friction model's first fit starts from (``shortlist``)
FRONT_STARTS = 4  # candidates of the screen's L-infinity front it starts from besides (``shortlist``)
RACE_EVALUATIONS = 60  # least-squares evaluations of a fit from each start; the best goes on to convergence
MAX_EVALUATIONS = 100  # least-squares evaluations of one run of a fit
CONTINUATIONS = 4  # restarts of a fit from where its budget stopped it
TOLERANCE = 1e-6
"""least_squares' xtol, ftol and gtol of the route's fits: chi^2 to a millionth, far below the BIC's evidence of
10 the loop decides by, where the calibration's 1e-10 costs iterations that change no decision."""


class Candidates(NamedTuple):
    """Designs of one friction model on one structure, evaluated at the measurement's amplitudes.

    labels: (k,) where each design comes from ("Sobol point 33"); designs: (k, d) parameters;
    frequency_hz, damping: (k, n) QSMA backbones with the borrowed zeta_0 (designs that did not converge at
    every level are left out); n_groups: the structure's patch groups.
    """

    model: str
    labels: list
    designs: np.ndarray
    frequency_hz: np.ndarray
    damping: np.ndarray
    n_groups: int


def evaluate_candidates(space: JointSpace, model: str, designs, labels, amplitude, linear_damping: float,
                        rule: str = "added") -> Candidates:
    """QSMA of the ``designs`` (k, d) of ``model`` on a structure's joint space at ``amplitude`` (n,) m kg^0.5,
    with the borrowed ``linear_damping`` made each design's zeta_0 by ``rule``."""
    designs = np.atleast_2d(np.asarray(designs, dtype=float))
    result = qsma_designs(space, model, designs, amplitudes=amplitude, linear_damping=0.0)
    kept = np.all(result.converged, axis=1)
    damping = result.damping + structure_damping(result.damping, [linear_damping], rule)
    return Candidates(model, [label for label, keep in zip(labels, kept) if keep], designs[kept],
                      result.frequency[kept] / (2 * np.pi), damping[kept],
                      int(np.max(space.superelement.patch_groups)) + 1)


def model_for_effects(effects, available) -> str | None:
    """The friction model of ``available`` that holds the friction effects among ``effects`` with the fewest
    others: stiction and a stuck core are parameters of an Iwan element and come with microslip (asked alone, they
    bring it, and the fit names it); None where no model holds them all (stiction with a stuck core)."""
    wanted = {effect for effect in effects if effect not in OUTSIDE_JOINT}
    holding = [model for model in available if wanted <= set(FRICTION_EFFECTS[model])]
    return min(holding, key=lambda model: len(FRICTION_EFFECTS[model]), default=None)


class StructureModel(NamedTuple):
    """What a fit on a structure's superelement needs: the measurement, the joint space, the borrowed damping
    case's value and the rule that makes it each design's zeta_0 (``study.errors.DAMPING_RULES``)."""

    measurement: BackboneLevels
    space: JointSpace
    borrowed_damping: float
    damping_rule: str = "added"


def screened_candidates(structure: StructureModel, model: str, n_groups: int) -> Candidates:
    """The first SCREEN_POINTS points of the unscrambled Sobol sequence over ``model``'s Table 3 unit box with
    ``n_groups`` parameter groups, evaluated on ``structure`` (``evaluate_candidates``; module docstring)."""
    limits = parameter_limits(model, n_groups)
    unit = qmc.Sobol(len(limits[0]), scramble=False).random(SCREEN_POINTS)
    measurement = structure.measurement
    return evaluate_candidates(structure.space, model, from_unit(unit, *limits),
                               [f"Sobol point {i}" for i in range(SCREEN_POINTS)], measurement.amplitude,
                               structure.borrowed_damping, structure.damping_rule)


def augmented(frequency_hz, joint_damping, parameters: dict, amplitude, structure: StructureModel):
    """Frequency (Hz) and damping (n,) of a joint's backbone (QSMA's frequency and the joint's own damping, (n,))
    on ``structure`` with the effects outside the joint that ``parameters`` hold (module docstring)."""
    frequency = frequency_hz * (1.0 + parameters.get("frequency_shift", 0.0))
    if "zeta_0" in parameters:
        zeta0 = parameters["zeta_0"]
    else:
        zeta0 = structure_damping(joint_damping[None, :], [structure.borrowed_damping], structure.damping_rule)[0, 0]
    damping = joint_damping + zeta0
    return outside_joint(frequency, damping, amplitude, parameters, float(frequency[0]), amplitude[-1])


def shortlist(measurement: BackboneLevels, candidates: Candidates, k: int, front: int = 0) -> np.ndarray:
    """Indices of the candidates a friction model's fits start from: the k best by chi^2 of frequency, of
    damping and of both (an effect outside the joint acts on one of the two, so a design that misses only the
    other can become the best), and the ``front`` of lowest chi^2 among the candidates non-dominated in the
    L-infinity errors of frequency and damping (paper Eqs. 26-27: the designs a study's Pareto front holds, which
    slip where the chi^2 ranking's best sit on the stuck joint's plateau)."""
    frequency = np.sum(((candidates.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2, 1)
    damping = np.sum(((candidates.damping - measurement.damping) / measurement.sigma_damping) ** 2, 1)
    ranked = [np.argsort(np.nan_to_num(chi, nan=np.inf), kind="stable")[:k]
              for chi in (frequency, damping, frequency + damping)]
    errors = np.column_stack([np.max(np.abs(candidates.frequency_hz - measurement.frequency_hz), axis=1),
                              np.max(np.abs(candidates.damping - measurement.damping), axis=1)])
    pareto = np.flatnonzero(non_dominated(errors))
    ranked.append(pareto[np.argsort(frequency[pareto] + damping[pareto], kind="stable")[:front]])
    return np.unique(np.concatenate(ranked))


def residual_rows(structure: StructureModel, model: str, n_groups: int, specification, points) -> np.ndarray:
    """Residuals (n, 2 levels) in units of the measurement's uncertainty of points (n, d + e): the joint design
    in the unit box (d) and the effects' variables (e, ``specification``); UNDEFINED_MISFIT where QSMA did not
    converge at every level."""
    points = np.atleast_2d(points)
    d = points.shape[1] - len(specification)
    measurement = structure.measurement
    designs = from_unit(points[:, :d], *parameter_limits(model, n_groups))
    result = qsma_designs(structure.space, model, designs, amplitudes=measurement.amplitude, linear_damping=0.0)
    rows = np.full((len(points), 2 * len(measurement.amplitude)), UNDEFINED_MISFIT)
    for row, (point, frequency, damping, converged) in enumerate(zip(points, result.frequency, result.damping,
                                                                     result.converged)):
        if converged.all():
            parameters = _to_parameters(point[d:], specification)
            rows[row] = weighted_misfit(measurement, *augmented(frequency / (2 * np.pi), damping, parameters,
                                                                measurement.amplitude, structure))
    return rows


def effects_on_design(structure: StructureModel, model: str, design, specification, values: dict) -> np.ndarray:
    """The effects' variables (e,) fitted by weighted least squares with the joint ``design`` (d,) held: one QSMA
    evaluation, then the effects alone on its backbone (from ``values``), the start of a fit of them all."""
    vector = _to_vector(values, specification)
    if not specification:
        return vector
    measurement = structure.measurement
    joint = qsma_designs(structure.space, model, np.asarray(design, dtype=float)[None, :],
                         amplitudes=measurement.amplitude, linear_damping=0.0)
    if not joint.converged.all():
        return vector

    def misfit(variables):
        return weighted_misfit(measurement, *augmented(joint.frequency[0] / (2 * np.pi), joint.damping[0],
                                                       _to_parameters(variables, specification),
                                                       measurement.amplitude, structure))

    with np.errstate(all="ignore"):
        return least_squares(misfit, vector, method="trf", x_scale="jac", max_nfev=200).x


def refit(structure: StructureModel, model: str, n_groups: int, effects: tuple, starts: list, scan: bool = False
          ) -> Fit:
    """The best weighted least-squares fit of ``model`` with the effects outside the joint among ``effects`` from
    each of ``starts`` ((label, design (d,) in physical units, effect parameters dict); missing parameters take
    the library's starts, then ``effects_on_design``'s fit on the start's backbone): each start fitted for
    RACE_EVALUATIONS, the best continued to convergence and, with ``scan``, scanned along each joint coordinate
    and fitted again from the best of the scans while that lowers chi^2 (module docstring)."""
    specification = [p for effect in effects if effect in OUTSIDE_JOINT for p in EFFECTS[effect].parameters]
    limits = parameter_limits(model, n_groups)
    d = len(limits[0])
    lower = np.concatenate([np.zeros(d), np.full(len(specification), -np.inf)])
    upper = np.concatenate([np.ones(d), np.full(len(specification), np.inf)])
    defaults = {"zeta_0": structure.borrowed_damping}

    def rows(points):
        return residual_rows(structure, model, n_groups, specification, points)

    def solved(start, evaluations=MAX_EVALUATIONS, continuations=CONTINUATIONS):
        with np.errstate(all="ignore"):
            result, _, _ = continued_least_squares(rows, start, lower, upper, evaluations, continuations, TOLERANCE)
        return float(2.0 * result.cost), result

    best = None
    for label, design, values in starts:
        effect_values = {name: values.get(name, defaults.get(name, initial)) for name, _, initial in specification}
        start = np.concatenate([to_unit(np.asarray(design, dtype=float), *limits),
                                effects_on_design(structure, model, design, specification, effect_values)])
        chi_squared, result = solved(start, RACE_EVALUATIONS, 0)
        if best is None or chi_squared < best[0]:
            best = (chi_squared, label, result)
    chi_squared, label, result = best
    if result.status == 0:
        chi_squared, result = solved(result.x)
    for _ in range(SCAN_SWEEPS if scan else 0):
        scans = coordinate_scans(result.x[:d])
        points = np.column_stack([scans, np.repeat(result.x[None, d:], len(scans), axis=0)])
        values = np.sum(rows(points) ** 2, axis=1)
        if not values.min() < chi_squared * (1.0 - SCAN_GAIN):
            break
        chi_squared, result = solved(points[np.argmin(values)])
        label = f"{label}, scanned"
    design = from_unit(result.x[None, :d], *limits)[0]
    parameters = _to_parameters(result.x[d:], specification)
    measurement = structure.measurement
    fitted = qsma_designs(structure.space, model, design[None, :], amplitudes=measurement.amplitude,
                          linear_damping=0.0)
    def with_effects(values):
        return augmented(fitted.frequency[0] / (2 * np.pi), fitted.damping[0], values, measurement.amplitude,
                         structure)

    frequency, damping = with_effects(parameters)
    full = [(name, "design", None) for name in parameter_names(model, n_groups)] + specification
    undetermined = determinacy(result.jac, result.x, full, range(d, d + len(specification)))
    named = dict(zip(parameter_names(model, n_groups), map(float, design)))
    return Fit(tuple(effects), {"design": f"{model}, refitted from {label}", "model": model, **named, **parameters},
               chi_squared, bic(chi_squared, d + len(specification), 2 * len(measurement.amplitude)), frequency,
               damping, d + len(specification), undetermined, converged=bool(result.status > 0),
               unresolved=unresolved_effects(measurement, [e for e in effects if e in OUTSIDE_JOINT], parameters,
                                             (frequency, damping), with_effects))


def fitted_design(fit: Fit, n_groups: int) -> tuple:
    """A refit's optimum as a start of another fit: (where it was refitted from, its design (d,) in physical
    units, its parameters dict)."""
    names = parameter_names(fit.parameters["model"], n_groups)
    return fit.parameters["design"].split("from ", 1)[1], np.array([fit.parameters[name] for name in names]), \
        fit.parameters


def contained_design(fit: Fit, model: str, n_groups: int) -> tuple:
    """The optimum of a refit (``fit``) of the model ``model`` contains (``FrictionModel.contains``) as a start of
    ``model``: its design in ``model``'s parameters with those ``model`` adds at
    ``nonlinear.friction_models.CONTAINED_UNIT`` (``nonlinear.joint.contained_unit_designs``), where the two
    models have the same backbone; (label, design (d,) in physical units, its parameters dict)."""
    inner = fit.parameters["model"]
    label, design, values = fitted_design(fit, n_groups)
    unit = contained_unit_designs(to_unit(design[None, :], *parameter_limits(inner, n_groups)), model, n_groups)
    return f"{inner} {label}", from_unit(unit, *parameter_limits(model, n_groups))[0], values


def structure_discrepancy_loop(measurement: BackboneLevels, candidates: dict, borrowed_damping: float,
                               space: JointSpace, damping_rule: str = "added") -> Verdict:
    """The loop (``discrepancy.loop.select_effects``) on a structure's superelement (``space``): ``candidates``
    maps friction models (at least the reference, Jenkins) to their ``Candidates`` (``screened_candidates``); the
    library is the effects outside the joint and the friction effects the available models hold."""
    if REFERENCE_MODEL not in candidates:
        raise ValueError(f"candidates: the reference friction model '{REFERENCE_MODEL}' is missing; got "
                         f"{sorted(candidates)}")
    library = OUTSIDE_JOINT + tuple(sorted({e for model in candidates for e in FRICTION_EFFECTS[model]}))
    structure = StructureModel(measurement, space, borrowed_damping, damping_rule)
    plain = {}  # friction model -> its fit with no effect outside the joint, where its later fits start
    best = {}  # effects (frozenset) -> the best fit of them so far: the contained model's start of a larger one

    def design_start(fit: Fit):
        return fitted_design(fit, candidates[fit.parameters["model"]].n_groups)

    def contained_start(effects, model: str) -> list:
        """The start ``model`` takes from the optimum of the model it contains with the same effects outside the
        joint (``contained_design``), fitted first: one start, or none where it contains none the loop has."""
        inner = FRICTION_MODELS[model].contains
        if inner not in candidates:
            return []
        inner_effects = tuple(e for e in effects if e in OUTSIDE_JOINT) + FRICTION_EFFECTS[inner]
        inner_fit = best.get(frozenset(inner_effects)) or fitted(inner_effects)
        return [] if inner_fit is None else [contained_design(inner_fit, model, candidates[model].n_groups)]

    def fitted(effects, previous=None, again=False):
        model = model_for_effects(effects, candidates)
        if model is None or not candidates[model].labels:
            return None
        effects = FRICTION_EFFECTS[model] + tuple(e for e in effects if e not in FRICTION_EFFECTS[model])
        found = candidates[model]

        def from_candidates(k, front=0):
            return [(found.labels[i], found.designs[i], {}) for i in shortlist(measurement, found, k, front)]

        def kept(fit: Fit) -> Fit:
            key = frozenset(fit.effects)
            if key not in best or fit.chi_squared < best[key].chi_squared:
                best[key] = fit
            return fit

        if again:  # fitted before from its own starts: from the other model's optimum alone, where it is a design
            if previous is None or previous.parameters["model"] != model:
                return None
            return kept(refit(structure, model, found.n_groups, tuple(effects), [design_start(previous)]))

        if model not in plain:
            joint_only = tuple(e for e in effects if e not in OUTSIDE_JOINT)
            plain[model] = kept(refit(structure, model, found.n_groups, joint_only,
                                      from_candidates(SHORTLIST, FRONT_STARTS) + contained_start(joint_only, model),
                                      scan=True))
        if set(effects) == set(plain[model].effects):
            return plain[model]
        starts = [design_start(plain[model])] + from_candidates(1) + contained_start(effects, model)
        if previous is not None and previous.parameters["model"] == model:
            starts.append(design_start(previous))
        return kept(refit(structure, model, found.n_groups, tuple(effects), starts))

    return select_effects(measurement, fitted, library)


class StudyStructure(NamedTuple):
    """What the loop needs from a study folder for one structure: its measurement at the study's levels (with its
    provenance and source), the screened candidates of each friction model the study explored, the borrowed damping
    case's value, the structure's joint space and the study's damping rule."""

    measurement: BackboneLevels
    candidates: dict
    borrowed_damping: float
    space: JointSpace
    damping_rule: str


def from_study(folder: Path, name: str) -> StudyStructure:
    """Read a study's results (``surrogacy study`` output ``folder``: study.json and measurements/) for the
    structure ``name`` and screen the starting designs of each friction model it explored
    (``screened_candidates``)."""
    _, parameters, explored = read_study(folder)
    if name not in explored.names:
        raise ValueError(f"{folder}: structure {name!r} not in the study; expected one of {explored.names}")
    index = explored.names.index(name)
    structure = explored.structures[index]
    borrowed = explored.damping_cases[dataset(parameters["study"].dataset).default_damping_case][index]
    fitted_on = StructureModel(structure.measurement, structure.space, borrowed, explored.damping_rule)
    candidates = {model: screened_candidates(fitted_on, model, explored.n_groups)
                  for model in FRICTION_EFFECTS if model in explored.models}
    return StudyStructure(structure.measurement, candidates, borrowed, structure.space, explored.damping_rule)
