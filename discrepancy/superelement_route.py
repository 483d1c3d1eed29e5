"""The discrepancy loop on a structure's own model: its superelement and friction model, with the study's fits as
the starting points. ``discrepancy.loop`` holds the loop, the effect library and the one-mode model for
measurements with no finite-element model behind them; this module puts the structure's QSMA in the one-mode
model's place.

Candidates. The designs of a friction model on a structure are the study's Pareto designs there (the sample's
front and NSGA-II's, ``fronts_<model>.csv``), evaluated by the study's QSMA (``qsma_designs``) at the
measurement's levels with the study's linear damping zeta_0 (borrowed, as the paper did, made each design's by the
study's damping rule, ``study.errors.structure_damping``). They are where the fits start, not the answer.

Fit. Every model the loop tries is fitted by weighted least squares (``calibration.local_fit.box_least_squares``:
trust-region reflective, the Jacobian by central differences through one vectorised QSMA call) over the friction
model's joint parameters in the study's unit box (log where Table 3 samples in log) and the parameters of the
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
model that holds the effect).

Reference. The macroslip model (Jenkins) fitted with no effect: what the best Jenkins joint on this superelement
misses. The loop itself (forward selection by BIC, honest-fit rules, stepwise swap and drop, "unexplained") is
``select_effects``.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from calibration.local_fit import box_least_squares
from nonlinear.condensation import JointSpace
from nonlinear.friction_models import FRICTION_MODELS
from nonlinear.joint import from_unit, parameter_limits, parameter_names, to_unit
from nonlinear.qsma_vectorised import qsma_designs
from study.datasets import DEFAULT_DAMPING_CASE
from discrepancy.loop import (EFFECTS, OUTSIDE_JOINT, UNDEFINED_MISFIT, Fit, Verdict, _to_parameters, _to_vector, bic,
                              determinacy, outside_joint, select_effects, weighted_misfit)
from study.errors import structure_damping
from study.structures import Measurement
from study.workflow import front_designs, read_study

FRICTION_EFFECTS = {name: model.discrepancy_effects for name, model in FRICTION_MODELS.items()
                    if model.discrepancy_effects is not None}
"""Friction model -> the friction effects it adds to the macroslip reference (``nonlinear.friction_models``)."""
REFERENCE_MODEL = next(name for name, effects in FRICTION_EFFECTS.items() if not effects)  # macroslip only
SHORTLIST = 2  # candidates per ranking a friction model's first fit starts from (``shortlist``)
MAX_EVALUATIONS = 60  # least-squares iterations of one fit from one start


class Candidates(NamedTuple):
    """The study's designs of one friction model on one structure, evaluated at the measurement's amplitudes.

    labels: (k,) where each design comes from ("sample 33261", "nsga2 4"); designs: (k, d) parameters;
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


def friction_model(effects, available) -> str | None:
    """The friction model of ``available`` whose effects are exactly the friction effects among ``effects`` (None
    if there is none: stiction, the theta of an Iwan element, comes only with microslip)."""
    wanted = {effect for effect in effects if effect not in OUTSIDE_JOINT}
    return next((model for model in available if set(FRICTION_EFFECTS[model]) == wanted), None)


class StructureModel(NamedTuple):
    """What a fit on a structure's superelement needs: the measurement, the joint space, the borrowed damping
    case's value and the rule that makes it each design's zeta_0 (``study.errors.DAMPING_RULES``)."""

    measurement: Measurement
    space: JointSpace
    borrowed_damping: float
    damping_rule: str = "added"


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


def shortlist(measurement: Measurement, candidates: Candidates, k: int) -> np.ndarray:
    """Indices of the candidates a friction model's fits start from: the k best by chi^2 of frequency, of
    damping and of both (an effect outside the joint acts on one of the two, so a design that misses only the
    other can become the best)."""
    frequency = np.sum(((candidates.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2, 1)
    damping = np.sum(((candidates.damping - measurement.damping) / measurement.sigma_damping) ** 2, 1)
    ranked = [np.argsort(np.nan_to_num(chi, nan=np.inf), kind="stable")[:k]
              for chi in (frequency, damping, frequency + damping)]
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


def refit(structure: StructureModel, model: str, n_groups: int, effects: tuple, starts: list) -> Fit:
    """The best weighted least-squares fit of ``model`` with the effects outside the joint among ``effects`` from
    each of ``starts`` ((label, design (d,) in physical units, effect parameters dict); missing parameters take
    the library's starts, then ``effects_on_design``'s fit on the start's backbone) (module docstring)."""
    specification = [p for effect in effects if effect in OUTSIDE_JOINT for p in EFFECTS[effect].parameters]
    limits = parameter_limits(model, n_groups)
    d = len(limits[0])
    lower = np.concatenate([np.zeros(d), np.full(len(specification), -np.inf)])
    upper = np.concatenate([np.ones(d), np.full(len(specification), np.inf)])
    defaults = {"zeta_0": structure.borrowed_damping}

    def rows(points):
        return residual_rows(structure, model, n_groups, specification, points)

    best = None
    for label, design, values in starts:
        effect_values = {name: values.get(name, defaults.get(name, initial)) for name, _, initial in specification}
        start = np.concatenate([to_unit(np.asarray(design, dtype=float), *limits),
                                effects_on_design(structure, model, design, specification, effect_values)])
        with np.errstate(all="ignore"):
            result = box_least_squares(rows, start, lower, upper, MAX_EVALUATIONS)
        chi_squared = float(2.0 * result.cost)
        if best is None or chi_squared < best[0]:
            best = (chi_squared, label, result)
    chi_squared, label, result = best
    design = from_unit(result.x[None, :d], *limits)[0]
    parameters = _to_parameters(result.x[d:], specification)
    measurement = structure.measurement
    fitted = qsma_designs(structure.space, model, design[None, :], amplitudes=measurement.amplitude,
                          linear_damping=0.0)
    frequency, damping = augmented(fitted.frequency[0] / (2 * np.pi), fitted.damping[0], parameters,
                                   measurement.amplitude, structure)
    full = [(name, "design", None) for name in parameter_names(model, n_groups)] + specification
    undetermined = determinacy(result.jac, result.x, full, range(d, d + len(specification)))
    named = dict(zip(parameter_names(model, n_groups), map(float, design)))
    return Fit(tuple(effects), {"design": f"{model}, refitted from {label}", "model": model, **named, **parameters},
               chi_squared, bic(chi_squared, d + len(specification), 2 * len(measurement.amplitude)), frequency,
               damping, d + len(specification), undetermined)


def structure_discrepancy_loop(measurement: Measurement, candidates: dict, borrowed_damping: float,
                               space: JointSpace, damping_rule: str = "added") -> Verdict:
    """The loop (``discrepancy.loop.select_effects``) on a structure's superelement (``space``): ``candidates``
    maps friction models (at least the reference, Jenkins) to their ``Candidates``; the library is the effects
    outside the joint and the friction effects the available models hold."""
    if REFERENCE_MODEL not in candidates:
        raise ValueError(f"candidates: the reference friction model '{REFERENCE_MODEL}' is missing; got "
                         f"{sorted(candidates)}")
    library = OUTSIDE_JOINT + tuple(sorted({e for model in candidates for e in FRICTION_EFFECTS[model]}))
    structure = StructureModel(measurement, space, borrowed_damping, damping_rule)
    plain = {}  # friction model -> its fit with no effect outside the joint, where its later fits start

    def design_start(fit: Fit):
        model = fit.parameters["model"]
        names = parameter_names(model, candidates[model].n_groups)
        return (fit.parameters["design"].split("from ", 1)[1], [fit.parameters[name] for name in names],
                fit.parameters)

    def fitted(effects, previous=None):
        model = friction_model(effects, candidates)
        if model is None or not candidates[model].labels:
            return None
        found = candidates[model]

        def from_candidates(k):
            return [(found.labels[i], found.designs[i], {}) for i in shortlist(measurement, found, k)]

        if model not in plain:
            plain[model] = refit(structure, model, found.n_groups,
                                 tuple(e for e in effects if e not in OUTSIDE_JOINT), from_candidates(SHORTLIST))
        if set(effects) == set(plain[model].effects):
            return plain[model]
        starts = [design_start(plain[model])] + from_candidates(1)
        if previous is not None and previous.parameters["model"] == model:
            starts.append(design_start(previous))
        return refit(structure, model, found.n_groups, tuple(effects), starts)

    return select_effects(measurement, fitted, library)


class StudyStructure(NamedTuple):
    """What the loop needs from a study folder for one structure: its measurement at the study's levels (with its
    provenance and source), the candidates of each friction model the study explored, the borrowed damping
    case's value, the structure's joint space and the study's damping rule."""

    measurement: Measurement
    candidates: dict
    borrowed_damping: float
    space: JointSpace
    damping_rule: str


def from_study(folder: Path, name: str) -> StudyStructure:
    """Read a study's results (``surrogacy study`` output ``folder``: study.json, measurements/, designs/,
    analysis/fronts_<model>.csv) for the structure ``name`` and evaluate its Pareto designs."""
    paths, parameters, explored = read_study(folder)
    if name not in explored.names:
        raise ValueError(f"{folder}: structure {name!r} not in the study; expected one of {explored.names}")
    index = explored.names.index(name)
    structure = explored.structures[index]
    borrowed = explored.damping_cases[DEFAULT_DAMPING_CASE[parameters["study"].dataset]][index]
    measurement = structure.measurement
    candidates = {}
    for model in (m for m in FRICTION_EFFECTS if m in explored.models):
        front = front_designs(paths, model, explored.n_groups, name)
        candidates[model] = evaluate_candidates(structure.space, model, front.designs, front.labels,
                                                measurement.amplitude, borrowed, explored.damping_rule)
    return StudyStructure(measurement, candidates, borrowed, structure.space, explored.damping_rule)
