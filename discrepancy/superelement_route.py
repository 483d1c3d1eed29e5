"""The discrepancy loop on a structure's own model: its superelement and friction model, with the study's fits as
the reference. ``discrepancy.loop`` holds the loop, the effect library and the one-mode
model for measurements with no finite-element model behind them; this module puts the study's evaluation in the
one-mode model's place.

Reference. The candidate designs of a friction model on a structure are the study's Pareto designs there (the
sample's front and NSGA-II's, ``fronts_<model>.csv``), evaluated by the study's QSMA (``qsma_designs``) at the
measurement's levels with the study's linear damping zeta_0 (borrowed, as the paper did). The reference model is
the candidate of the study's macroslip model (Jenkins) with the lowest chi^2 against the measurement (weighted by
its uncertainty, as in ``discrepancy.loop``); its residual is what the study's best fit misses.

Effects. The friction effects change the friction model and refit by choosing again among the study's designs:
microslip = the Iwan element (iwan4), microslip with stiction = iwan5 (theta < 1), microslip with a stuck core =
iwan4_core (K_c, a spring beside each element that never slips); each counts its model's parameters in the BIC.
The effects outside the joint act on the chosen design's backbone f(q), zeta(q) and are fitted by weighted least
squares on the candidates closest to the measurement in frequency, in damping and in both (``shortlist``; the best
pair is kept):

    linear_damping     zeta(q) - zeta_0 + zeta_0'          (a structure-specific linear damping, zeta_0' free)
    stiffness_change   f(q) (1 + s)                         (a linear stiffness or mass change outside the joint;
                                                             the joint's share of the stiffness is kept)
    amplitude_damping  zeta(q) + c q / q_max
    cubic_stiffening   sqrt(f(q)^2 + gamma f(q_min)^2 (q / q_max)^2)

The loop itself (forward selection by BIC, stepwise swap and drop, "unexplained") is ``select_effects``.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from nonlinear.friction_models import FRICTION_MODELS
from nonlinear.qsma_vectorised import qsma_designs
from study.datasets import DEFAULT_DAMPING_CASE
from discrepancy.loop import (EFFECTS, Fit, Verdict, _to_parameters, _to_vector, bic, outside_joint,
                               select_effects, weighted_misfit)
from study.structures import Measurement
from study.workflow import front_designs, read_study

FRICTION_EFFECTS = {name: model.discrepancy_effects for name, model in FRICTION_MODELS.items()
                    if model.discrepancy_effects is not None}
"""Friction model -> the friction effects it adds to the macroslip reference (``nonlinear.friction_models``)."""
OUTSIDE_JOINT = ("linear_damping", "stiffness_change", "amplitude_damping", "cubic_stiffening")
REFERENCE_MODEL = next(name for name, effects in FRICTION_EFFECTS.items() if not effects)  # macroslip only
SHORTLIST = 8  # candidates per ranking refitted with effects outside the joint (``shortlist``)


class Candidates(NamedTuple):
    """The study's designs of one friction model on one structure, evaluated at the measurement's amplitudes.

    labels: (k,) where each design comes from ("sample 33261", "nsga2 4"); designs: (k, d) parameters;
    frequency_hz, damping: (k, n) QSMA backbones with the borrowed zeta_0 (designs that did not converge at
    every level are left out); n_parameters: d, the friction model's parameters (counted in the BIC).
    """

    model: str
    labels: list
    designs: np.ndarray
    frequency_hz: np.ndarray
    damping: np.ndarray
    n_parameters: int


def evaluate_candidates(space, model: str, designs, labels, amplitude, linear_damping: float) -> Candidates:
    """QSMA of the ``designs`` (k, d) of ``model`` on a structure's joint space at ``amplitude`` (n,) m kg^0.5."""
    designs = np.atleast_2d(np.asarray(designs, dtype=float))
    result = qsma_designs(space, model, designs, amplitudes=amplitude, linear_damping=linear_damping)
    kept = np.all(result.converged, axis=1)
    return Candidates(model, [label for label, keep in zip(labels, kept) if keep], designs[kept],
                      result.frequency[kept] / (2 * np.pi), result.damping[kept], designs.shape[1])


def friction_model(effects, available) -> str | None:
    """The friction model of ``available`` whose effects are exactly the friction effects among ``effects`` (None
    if there is none: stiction, the theta of an Iwan element, comes only with microslip)."""
    wanted = {effect for effect in effects if effect not in OUTSIDE_JOINT}
    return next((model for model in available if set(FRICTION_EFFECTS[model]) == wanted), None)


def augmented(candidates: Candidates, index: int, parameters: dict, amplitude, borrowed_damping: float):
    """Frequency (Hz) and damping (n,) of candidate ``index`` with the effects outside the joint that
    ``parameters`` hold (module docstring)."""
    frequency = candidates.frequency_hz[index] * (1.0 + parameters.get("frequency_shift", 0.0))
    damping = candidates.damping[index] - borrowed_damping + parameters.get("zeta_0", borrowed_damping)
    return outside_joint(frequency, damping, amplitude, parameters, float(frequency[0]))


def shortlist(measurement: Measurement, candidates: Candidates, k: int) -> np.ndarray:
    """Indices of the candidates worth refitting with effects outside the joint: the k best by chi^2 of
    frequency, of damping and of both (the effects act on one of the two, so a design that misses only the other
    can become the best)."""
    frequency = np.sum(((candidates.frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency) ** 2, 1)
    damping = np.sum(((candidates.damping - measurement.damping) / measurement.sigma_damping) ** 2, 1)
    ranked = [np.argsort(np.nan_to_num(chi, nan=np.inf), kind="stable")[:k]
              for chi in (frequency, damping, frequency + damping)]
    return np.unique(np.concatenate(ranked))


def fit_candidates(measurement: Measurement, candidates: Candidates, effects: tuple, borrowed_damping: float,
                   previous: dict | None = None) -> Fit | None:
    """The best design of ``candidates`` with the effects outside the joint among ``effects`` fitted to it by
    weighted least squares (starts: the library's, and ``previous``'s values); None without candidates."""
    if not candidates.labels:
        return None
    specification = [p for effect in effects if effect in OUTSIDE_JOINT for p in EFFECTS[effect]]
    initial_values = {"zeta_0": borrowed_damping}
    start = {name: (previous or {}).get(name, initial_values.get(name, initial))
             for name, _, initial in specification}

    def misfit(index, parameters):
        return weighted_misfit(measurement, *augmented(candidates, index, parameters, measurement.amplitude,
                                                       borrowed_damping))

    best = None
    for index in shortlist(measurement, candidates, SHORTLIST if specification else len(candidates.labels)):
        if specification:
            with np.errstate(all="ignore"):
                result = least_squares(lambda v: misfit(index, _to_parameters(v, specification)),
                                       _to_vector(start, specification), method="trf", x_scale="jac", max_nfev=200)
            parameters = _to_parameters(result.x, specification)
        else:
            parameters = {}
        chi_squared = float(np.sum(misfit(index, parameters) ** 2))
        if best is None or chi_squared < best[0]:
            best = (chi_squared, index, parameters)
    chi_squared, index, parameters = best
    frequency, damping = augmented(candidates, index, parameters, measurement.amplitude, borrowed_damping)
    n_parameters = candidates.n_parameters + len(specification)
    return Fit(tuple(effects), {"design": f"{candidates.model} {candidates.labels[index]}", **parameters},
               chi_squared, bic(chi_squared, n_parameters, 2 * len(measurement.amplitude)), frequency, damping,
               n_parameters)


def structure_discrepancy_loop(measurement: Measurement, candidates: dict, borrowed_damping: float) -> Verdict:
    """The loop (``discrepancy.loop.select_effects``) on a structure's superelement: ``candidates`` maps friction
    models (at least the reference, Jenkins) to their ``Candidates``; the library is the effects outside the
    joint and the friction effects the available models hold."""
    if REFERENCE_MODEL not in candidates:
        raise ValueError(f"candidates: the reference friction model '{REFERENCE_MODEL}' is missing; got "
                         f"{sorted(candidates)}")
    library = OUTSIDE_JOINT + tuple(sorted({e for model in candidates for e in FRICTION_EFFECTS[model]}))

    def fitted(effects, previous=None):
        model = friction_model(effects, candidates)
        if model is None:
            return None
        return fit_candidates(measurement, candidates[model], tuple(effects), borrowed_damping,
                              previous.parameters if previous is not None else None)

    return select_effects(measurement, fitted, library)


class StudyStructure(NamedTuple):
    """What the loop needs from a study folder for one structure: its measurement at the study's levels (with its
    provenance and source), the candidates of each friction model the study explored, the borrowed zeta_0."""

    measurement: Measurement
    candidates: dict
    borrowed_damping: float


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
                                                measurement.amplitude, borrowed)
    return StudyStructure(measurement, candidates, borrowed)
