"""The model-discrepancy loop (docs/design.md section 8): from a measured backbone and a model that does not fit it,
find which missing effect explains the residual, add it, refit, and report the error before and after; answer
"unexplained" rather than guess.

Model. The one-mode joint model of ``nonlinear.modal_joint`` (a linear mode plus a Jenkins element, the
macroslip reference) with the structure's nominal low-amplitude frequency f_0 and linear damping zeta_0 fixed
(from the structure's model and its borrowed damping, as the paper did), and the joint's stiffness share kappa and
slip force F_S fitted. Each effect of the one-mode library (``discrepancy.effects``: microslip, stiction and a
second slip stage in the joint's friction law, the others outside the joint) adds a documented term and its
parameters.

q_max is the largest fitted amplitude (the model's amplitude scale, recorded with the final model:
``discrepancy.fitted_model``).

Fit. Weighted least squares (scipy.optimize.least_squares) of frequency and damping against the measurement,
each residual divided by the measurement's standard uncertainty (with floors of 1e-4 f and 2 % of zeta); positive
parameters in log, bounded ones through a logistic map; several starts; the forward-difference Jacobian's p + 1
parameter sets evaluated as the rows of one call of the model (``forward_difference_jacobian``). The variables'
covariance is that of the weighted least-squares optimum (``parameter_covariance``).

Limits of a law. chi -> 0 (dissipation about linear in amplitude; chi = -0.005, the end of its range) and
beta -> 0 (Iwan's density without its spike) are values of Iwan's law, not parameters the points leave free: every
fit with microslip is refitted with each held at its limit in turn (``PHYSICAL_LIMITS``), and each stays held where
freeing it lowers chi^2 by less than ``LIMIT_TEST`` (a likelihood-ratio test at 5 % against the 50:50 mixture of
chi^2_0 and chi^2_1 that a parameter on the boundary of its range follows): a constrained optimum with one
parameter fewer, recorded as held with its evidence.

A stiction drop. With stiction (theta < 1) an element's force drops at its slip amplitude phi_max: the backbone
jumps there, and a fit's optimum can put the drop on a measured level, the rest of its chi^2 pulling the drop
across and the jump holding it back (the measured ASB C2 and C4 stiction models, to 3e-8 and 9e-8 of the level).
The least squares only creep along such a boundary, so a fit whose optimum sits on a drop is fitted again with
each such slip amplitude kept where it is (``along_levels``: the smooth problem's optimum on that boundary; C4's
answer went from BIC 414.92 to 404.73). A forward difference across the drop is the jump over the step, not a
slope: such a Jacobian column is the other side's difference (``across_jumps``), and the points place the drop
only between that level and the next one on its stuck side, a gap of ln phi_max taken as uniform in the
covariance (``stiction_drops``; recorded as the fit's ``on_drop``).

Determined. A fit's other effect parameters must be determined by the points: at the optimum, with J the Jacobian
of the residuals in units of the measurement's uncertainty (what the points determine at their stated noise,
whatever the model still misses), the covariance of the effect parameters with the others held is
(J_e^T J_e)^-1 (J_e their columns of J; singular values floored at ``SINGULAR_FLOOR`` of J's scale, so a direction
the points do not see gets a huge variance instead of being dropped). The joint's own parameters are held because
their trade against an effect is not local: a Jenkins joint on a superelement mimics a 0.4 % frequency shift to
first order (its Jacobian spans the shift's column to 2e-8) but not over the whole backbone, where only the shift
fits. A parameter is "at its bound" where its bounded map sits within ``AT_BOUND`` of an end that is a box edge,
not a law's limit (a frequency shift of +-10 %; theta at 1, where stiction vanishes, or at 0), and "not
determined" where the standard deviation of its fitted variable exceeds ``UNDETERMINED`` (3 in the log of a
positive parameter: a factor 20 either way; 3 in the logit of a bounded one): more parameters than the points
carry. Whether the effect is there at all is the BIC's question (below), not the covariance's. A trial with such
a parameter is not accepted, whatever its BIC; the step lists it with the reason. Nor is one with an effect below
the measurement's resolution (``unresolved_effects``): switched off, it moves no level by its standard uncertainty.

Loop. Starting from the reference model, every effect not yet in the model is added and refitted; the one with
the lowest Bayesian information criterion BIC = chi^2 + k ln n (n residuals, k parameters) is kept if it lowers
the BIC by more than ``EVIDENCE`` (10: very strong evidence), its parameters are determined, and it leaves
neither L-infinity error (frequency, damping) worse than the reference model's by more than the measurement's
largest standard uncertainty (a least-squares optimum can trade the worst point for the rest). This greedy path
stops when the residual is at the measurement's noise (chi^2 per degree of freedom below ``AT_NOISE``) or no
effect earns its parameters; forward paths from the next-best first steps (``other_first_steps``), branching into
the ``BRANCHES`` best additions at their first step and going on past the noise while an addition earns its
parameters (``climb``), and a stepwise refinement then try other combinations. Every model fitted is kept: a model
reached again from another model's optimum is fitted again from it alone (each start once), and the refit replaces
the fit where it is accepted and the fit is not, or, both alike, where it lowers the BIC by more than ``SETTLED``;
and, until no fit moves, each model is fitted again from the optimum of every model one effect larger or smaller
that fits better than it, where that could make it a candidate answer (``refit_nested``), so the optimum a model
reaches does not hang on the path that first reached it. Nor on Iwan's shape: every start of the loop's own has
the library's (chi, beta), and each candidate answer with microslip is fitted again from its optimum with each
shape of ``SHAPES`` (``restart_candidates``: 21 starts, too many for every model the loop fits). The answer
(``final_model``): among every fitted model that meets the acceptance rules, those within ``EVIDENCE`` of the lowest
BIC that hold none of the others (each further effect of a model must earn its parameters against the models it
holds); of these the one with the lowest BIC. The loop never ends on a model worse by its own criterion than one it
evaluated, and the other such models are reported beside it as answers the data do not tell apart; the models it
evaluated that fit better than it by more than ``EVIDENCE`` but that the rules refuse are named with the reasons.
A residual still above ``UNEXPLAINED`` times the noise is reported as unexplained. Each step records the effect,
the parameters, chi^2, BIC, the L-infinity and RMS errors of frequency and damping, and the candidates not
accepted with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import product
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares
from scipy.special import expit, logit

from discrepancy.effects import EFFECTS, ONE_MODE_EFFECTS, SECOND_STAGE, STAGE_SUFFIX
from nonlinear.modal_joint import modal_joint_backbone, slip_amplitudes
from study.structures import BackboneLevels

EVIDENCE = 10.0  # BIC decrease an effect must bring to be added
AT_NOISE = 1.5  # chi^2 per degree of freedom at which the residual is the measurement's noise
UNEXPLAINED = 3.0  # chi^2 per degree of freedom above which a remaining residual is reported unexplained
UNDEFINED_MISFIT = 1e8  # residual given to a point where the model is undefined (the optimiser moves away)
AT_BOUND = 1e-2  # fraction of a bounded parameter's range from an end at which it sits on its bound
UNDETERMINED = 3.0  # standard deviation of a fitted variable (log or logit) above which the points leave it free
SINGULAR_FLOOR = 1e-12  # singular values floored at this fraction of the Jacobian's largest entry

MAX_SHIFT = 0.1  # largest relative frequency change outside the joint (a sensor's mass, a mis-set modulus: percents)
OTHER_PATHS = 2  # forward paths from the next-best first steps beside the greedy one (``other_first_steps``)
BRANCHES = 2  # the best additions a forward path branches into at its first step (``climb``)
ZETA_START = 1e-6  # least start of a fitted linear damping (a nominal of 0 would start its log at -inf)
SETTLED = 0.1  # BIC decrease by which a refit replaces a model's fit (less is the least squares' own tolerance)
LIMIT_TEST = 2.706  # likelihood ratio above which a parameter is away from its law's limit (5 %, 50:50 chi^2_0/chi^2_1)
JUMP = 10.0  # one-sided differences of a column this many times apart: the larger crossed a jump (not a slope)
ON_DROP = 1e-6  # relative distance of a level from an element's slip amplitude at which it sits on stiction's drop
SHAPES = tuple(product((-0.2, -0.5, -0.8), (3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0, 3.0)))  # Iwan's (chi, beta) of restarts


BASE = (("kappa", "unit", 0.3), ("slip_force", "log", None))


def model_backbone(parameters: dict, amplitude, nominal_frequency_hz: float, nominal_damping: float,
                   amplitude_scale: float):
    """Frequency (Hz) and damping (n,) of the one-mode model with the effects its ``parameters`` hold (module
    docstring) at amplitudes (n,); ``amplitude_scale`` is q_max, the amplitude the effects outside the joint are
    scaled by (the largest fitted amplitude); missing effect parameters mean the effect is absent."""
    q = np.asarray(amplitude, dtype=float)
    stuck_frequency = nominal_frequency_hz * (1.0 + parameters.get("frequency_shift", 0.0))
    second_stage = (parameters["kappa" + STAGE_SUFFIX], parameters["slip_force" + STAGE_SUFFIX]) \
        if "kappa" + STAGE_SUFFIX in parameters else None
    frequency, damping = modal_joint_backbone(q, stuck_frequency, parameters["kappa"], parameters["slip_force"],
                                              parameters.get("chi"), parameters.get("beta", 0.0),
                                              parameters.get("theta", 1.0), second_stage)
    return outside_joint(frequency, damping + parameters.get("zeta_0", nominal_damping), q, parameters,
                         stuck_frequency, amplitude_scale)


def outside_joint(frequency, damping, amplitude, parameters: dict, linear_frequency_hz: float,
                  amplitude_scale: float):
    """The amplitude-dependent effects outside the joint on a backbone (frequency (n,) Hz, damping (n,) at the
    amplitudes (n,)): cubic stiffening omega^2 + gamma omega_0^2 (q / q_max)^2 and damping c q / q_max, q_max the
    ``amplitude_scale`` (module docstring); absent parameters leave the backbone as it is."""
    scaled = np.asarray(amplitude, dtype=float) / amplitude_scale
    if "cubic" in parameters:
        frequency = np.sqrt(frequency ** 2 + parameters["cubic"] * linear_frequency_hz ** 2 * scaled ** 2)
    return frequency, damping + parameters.get("air_damping", 0.0) * scaled


def _logit(p):
    """logit kept finite at the ends of a bounded map (a previous fit may sit on a bound)."""
    return logit(np.clip(p, 1e-12, 1.0 - 1e-12))


# kind -> (map from the fitted variable to the parameter, its inverse); bounded maps stay inside the open
# intervals the element laws require however far the optimiser goes.
TRANSFORMS = {
    "log": (lambda v: np.exp(np.clip(v, -300.0, 300.0)), lambda p: np.log(np.clip(p, 1e-300, 1e300))),
    "unit": (lambda v: 1e-6 + (1 - 2e-6) * expit(v), lambda p: _logit((p - 1e-6) / (1 - 2e-6))),
    "chi": (lambda v: -0.005 - 0.99 * expit(v), lambda p: _logit((-p - 0.005) / 0.99)),
    "shift": (lambda v: MAX_SHIFT * (2 * expit(v) - 1), lambda p: _logit((p / MAX_SHIFT + 1) / 2)),
}


def _to_parameters(vector, specification) -> dict:
    return {name: TRANSFORMS[kind][0](value) for value, (name, kind, _) in zip(vector, specification)}


def _to_vector(parameters: dict, specification) -> np.ndarray:
    return np.array([TRANSFORMS[kind][1](parameters[name]) for name, kind, _ in specification], dtype=float)


class Fit(NamedTuple):
    """A fitted model: its effects, parameters, chi^2, BIC and model curves at the measured amplitudes, the number
    of parameters fitted, its effect parameters that the points leave at a bound or undetermined
    (``determinacy``: name -> reason), those held at their law's limit (``held``: name -> the evidence), the
    covariance of its variables and whether its least squares stopped on its tolerances (``converged``), not on
    its evaluation budget, its effects whose own change of the model is below the measurement's resolution
    (``unresolved``: effect -> reason), and its elements whose stiction drop sits on a measured level
    (``on_drop``: element -> what the points tell of its slip amplitude; ``stiction_drops``)."""

    effects: tuple
    parameters: dict
    chi_squared: float
    bic: float
    frequency_hz: np.ndarray
    damping: np.ndarray
    n_parameters: int
    undetermined: dict = {}
    held: dict = {}
    covariance: np.ndarray | None = None
    converged: bool = False
    unresolved: dict = {}
    on_drop: dict = {}


PHYSICAL_LIMITS = {
    "chi": (float(logit(1e-12)), "Iwan's law at chi -> 0 (chi = -0.005, the end of its range: dissipation about "
                                 "linear in amplitude)"),
    "beta": (-300.0, "Iwan's law without its spike, beta -> 0 (the power-law density alone)"),
}
"""Parameter -> (its fitted variable at a limit of the element's law, not a box edge; what the limit means). Every
fit with such a parameter is refitted with it held there, one after the other, and it stays held where freeing it
lowers chi^2 by less than ``LIMIT_TEST`` (``fit``): a constrained optimum with one parameter fewer."""


def determinacy(jacobian, vector, specification, indices) -> dict:
    """Parameter name -> reason ("at its bound (value)", "not determined (value, ...)") for the effect parameters
    at ``indices`` of a least-squares optimum ``vector`` (p,) of fitted variables (``TRANSFORMS`` of
    ``specification``), from the residual's ``jacobian`` (m, p) (module docstring)."""
    jacobian = np.asarray(jacobian, dtype=float)
    indices = list(indices)
    if not indices:
        return {}
    _, singular, rows = np.linalg.svd(jacobian[:, indices], full_matrices=False)
    floor = max(SINGULAR_FLOOR * float(np.max(np.abs(jacobian))), np.finfo(float).tiny)
    with np.errstate(over="ignore"):  # a parameter the points do not see at all: an infinite spread
        spread = np.sqrt(np.sum((rows / np.maximum(singular, floor)[:, None]) ** 2, axis=0))
    reasons = {}
    for position, index in enumerate(indices):
        name, kind, _ = specification[index]
        value = float(TRANSFORMS[kind][0](vector[index]))
        if kind != "log" and not AT_BOUND < expit(vector[index]) < 1.0 - AT_BOUND:
            reasons[name] = f"at its bound ({value:.4g})"
        elif spread[position] > UNDETERMINED:
            reasons[name] = (f"not determined ({value:.4g}, standard deviation {spread[position]:.2g} in its "
                             f"{'log' if kind == 'log' else 'logit'})")
    return reasons


def weighted_misfit(measurement: BackboneLevels, frequency_hz, damping) -> np.ndarray:
    """Residuals (2n,) of a model's frequency (Hz) and damping (n,) against the measurement, each in units of the
    measurement's uncertainty; UNDEFINED_MISFIT where the model is undefined (e.g. a start past a law's range)."""
    misfit = np.concatenate([(frequency_hz - measurement.frequency_hz) / measurement.sigma_frequency,
                             (damping - measurement.damping) / measurement.sigma_damping], axis=-1)
    return np.where(np.isfinite(misfit), misfit, UNDEFINED_MISFIT)


def forward_difference_jacobian(residuals, vector) -> np.ndarray:
    """Jacobian (m, p) of the residuals at ``vector`` (p,) by forward differences, the p + 1 evaluations in one
    call of ``residuals`` (rows of variables (b, p) -> residuals (b, m)); each step is scipy's "2-point" step,
    sqrt(eps) max(1, |v_i|) with the sign of v_i, rounded to a representable increment."""
    vector = np.asarray(vector, dtype=float)
    step = np.sqrt(np.finfo(float).eps) * np.where(vector >= 0.0, 1.0, -1.0) * np.maximum(1.0, np.abs(vector))
    step = (vector + step) - vector
    values = residuals(np.vstack([vector, vector + np.diag(step)]))
    return ((values[1:] - values[0]) / step[:, None]).T


def best_least_squares(residuals, starts, held: dict):
    """The lowest-chi^2 trust-region least-squares optimum of ``residuals`` (rows of variables (b, p) -> rows of
    residuals (b, m), so that a Jacobian is one call: ``forward_difference_jacobian``) over the variables not in
    ``held`` (index -> value kept fixed), from each start (p,): (chi^2, vector (p,), Jacobian (m, p) with zero
    columns for the held variables, whether its least squares stopped on its tolerances)."""
    template = np.asarray(starts[0], dtype=float).copy()
    free = np.array([index for index in range(template.size) if index not in held], dtype=int)
    template[list(held)] = list(held.values())

    def full(variables):
        rows = np.array(np.broadcast_to(template, (*np.shape(variables)[:-1], template.size)))
        rows[..., free] = variables
        return rows

    def one(variables):
        return residuals(full(variables)[None])[0]

    def jacobian_of(variables):
        return forward_difference_jacobian(lambda rows: residuals(full(rows)), variables)

    best = None
    for start in starts:
        with np.errstate(all="ignore"):
            result = least_squares(one, np.asarray(start, dtype=float)[free], jac=jacobian_of, method="trf",
                                   x_scale="jac", max_nfev=400)
        chi_squared = float(np.sum(result.fun ** 2))
        if np.isfinite(chi_squared) and (best is None or chi_squared < best[0]):
            jacobian = np.zeros((result.jac.shape[0], template.size))
            jacobian[:, free] = result.jac
            best = (chi_squared, full(result.x), jacobian, bool(result.status > 0))
    return best


def fit(measurement: BackboneLevels, effects: tuple, nominal_frequency_hz: float, nominal_damping: float,
        starts: list[dict], nominal_uncertainty: tuple[float, float] = (0.0, 0.0)) -> Fit:
    """Weighted least-squares fit of the model with ``effects`` from each of ``starts`` (parameter dicts; missing
    entries take the library's start values); the best fit. Each effect parameter with a limit of its law
    (``PHYSICAL_LIMITS``) is then refitted held there, one after the other from the optimum, and stays held where
    the likelihood ratio of freeing it, chi^2_held - chi^2_free, is below ``LIMIT_TEST`` (the 5 % point of the
    50:50 mixture of chi^2_0 and chi^2_1 that a parameter on the boundary of its range follows): a constrained
    optimum with one parameter fewer. The held fit starts from the free optimum and from every start with the
    held value put in: Iwan's law has several optima, and the constrained one need not lie beside the free one
    (a clean ring-down of an Iwan joint held from the free optimum alone ended at chi^2/dof 1.54, above the
    noise, where the constrained optimum is at 1.28; any effect then lowered the BIC and was named).

    A nominal estimated from the measurement itself (``nominal_uncertainty``: its standard errors, Hz and -; 0 for
    a nominal given) is not exact: its frequency shift s and linear damping zeta_0' are fitted with a Gaussian
    prior residual each, s f_0 / sigma_f and (zeta_0' - zeta_0) / sigma_zeta (``nominal_priors``), and count as no
    parameter, unless an effect frees them (stiffness_change, linear_damping), which then pays its parameter and
    loses the prior: an offset within the nominal's uncertainty earns nothing."""
    priors = nominal_priors(effects, nominal_frequency_hz, nominal_damping, nominal_uncertainty)
    specification = model_variables(effects) + [variable for variable, _ in priors]
    defaults = {"zeta_0": max(nominal_damping, ZETA_START), "slip_force": None}
    n = 2 * len(measurement.amplitude)

    def at_levels(parameters):
        return model_backbone(parameters, measurement.amplitude, nominal_frequency_hz, nominal_damping,
                              measurement.amplitude[-1])

    def residuals(rows):
        parameters = _to_parameters(rows.T[:, :, None], specification)
        misfit = weighted_misfit(measurement, *at_levels(parameters))
        return np.concatenate([misfit, *(prior(parameters) for _, prior in priors)], axis=-1)

    vectors = [_to_vector({name: start.get(name, defaults.get(name, initial)) for name, _, initial in specification},
                          specification) for start in starts]
    effect_indices = range(len(BASE), len(specification) - len(priors))
    chi_squared, vector, jacobian, converged = best_least_squares(residuals, vectors, {})
    held, values = {}, {}
    for index in (index for index in effect_indices if specification[index][0] in PHYSICAL_LIMITS):
        name = specification[index][0]
        trial = {**values, index: PHYSICAL_LIMITS[name][0]}
        constrained = best_least_squares(residuals, [vector, *vectors], trial)
        ratio = constrained[0] - chi_squared
        if ratio < LIMIT_TEST:
            chi_squared, vector, jacobian, converged = constrained
            values = trial
            held[name] = (f"held at its law's limit, {PHYSICAL_LIMITS[name][1]}: freeing it lowers chi^2 by "
                          f"{max(ratio, 0.0):.3g} < {LIMIT_TEST}")
    on_drops = levels_on_drops(vector, specification, measurement.amplitude, nominal_frequency_hz)
    if on_drops:
        along = along_levels(residuals, vector, specification, nominal_frequency_hz, on_drops, values)
        if along[0] < chi_squared:
            chi_squared, vector, jacobian, converged = along
    parameters = _to_parameters(vector, specification)
    frequency, damping = at_levels(parameters)
    on_drop, gaps = stiction_drops(vector, specification, measurement.amplitude, nominal_frequency_hz)
    jacobian = smooth_jacobian(residuals, vector, jacobian)
    gaps[:, list(values)] = 0.0
    held_names = set(held)
    undetermined = determinacy(np.vstack([jacobian, gaps]), vector, specification,
                               [i for i in effect_indices if specification[i][0] not in held_names])
    k = len(specification) - len(priors) - len(held)
    unresolved = unresolved_effects(measurement, effects, parameters, (frequency, damping), at_levels)
    return Fit(tuple(effects), parameters, chi_squared, bic(chi_squared, k, n), frequency, damping, k, undetermined,
               held, parameter_covariance(jacobian, chi_squared, n - k, gaps), converged, unresolved, on_drop)


def smooth_jacobian(residuals, vector, jacobian) -> np.ndarray:
    """The forward-difference Jacobian (m, p) of ``residuals`` (rows of variables (b, p) -> residuals (b, m)) at
    ``vector`` (p,), ``jacobian`` (``forward_difference_jacobian``'s), with each column that crosses a jump of the
    residuals replaced by the backward difference (``across_jumps``)."""
    backward = -forward_difference_jacobian(lambda rows: residuals(2.0 * vector - rows), vector)
    return across_jumps(jacobian, jacobian, backward)


def across_jumps(difference, forward, backward) -> np.ndarray:
    """``difference`` (m, p), a derivative's estimate by columns (one per variable), with each column where one of
    the one-sided differences ``forward``, ``backward`` (m, p) has ``JUMP`` times the other's norm or more replaced
    by the other: that one crossed a jump of the function, and gives the jump divided by the step, not a slope (a
    stiction drop moved across a level by a step of 1e-8: a column of 1.5e8 on the measured ASB C2 where the other
    side's is 71, which pins its variable in a covariance); the other is the slope of the side the point is on."""
    forward_norm, backward_norm = np.linalg.norm(forward, axis=0), np.linalg.norm(backward, axis=0)
    return np.where(forward_norm >= JUMP * backward_norm, backward,
                    np.where(backward_norm >= JUMP * forward_norm, forward, difference))


ELEMENTS = (("joint element", ""), ("second slip stage", STAGE_SUFFIX))
"""The one-mode model's slip elements: (name, the suffix of their parameters kappa and slip_force)."""


def log_slip_amplitudes(rows, specification, nominal_frequency_hz: float) -> np.ndarray:
    """ln phi_max (b, elements) of the elements (``ELEMENTS`` the model holds) at rows of variables (b, p) of
    ``specification`` (``nonlinear.modal_joint.slip_amplitudes``); phi_max is proportional to the element's slip
    force in both laws."""
    p = _to_parameters(np.asarray(rows, dtype=float).T, specification)
    second = (p["kappa" + STAGE_SUFFIX], p["slip_force" + STAGE_SUFFIX]) if "kappa" + STAGE_SUFFIX in p else None
    return np.log(np.array(slip_amplitudes(nominal_frequency_hz * (1.0 + p.get("frequency_shift", 0.0)), p["kappa"],
                                           p["slip_force"], p.get("chi"), p.get("beta", 0.0), second))).T


def levels_on_drops(vector, specification, amplitude, nominal_frequency_hz: float) -> dict:
    """Element (index in ``ELEMENTS``) -> the level (index in ``amplitude`` (n,), increasing) its stiction drop sits
    on: with stiction (theta < 1), a level within ``ON_DROP`` of the element's slip amplitude, relative."""
    if _to_parameters(vector, specification).get("theta", 1.0) >= 1.0:
        return {}
    amplitude = np.asarray(amplitude, dtype=float)
    slip = np.exp(log_slip_amplitudes(np.asarray(vector)[None], specification, nominal_frequency_hz)[0])
    levels = [int(np.argmin(np.abs(amplitude / phi_max - 1.0))) for phi_max in slip]
    return {element: level for element, (level, phi_max) in enumerate(zip(levels, slip))
            if abs(amplitude[level] / phi_max - 1.0) <= ON_DROP}


def stiction_drops(vector, specification, amplitude, nominal_frequency_hz: float) -> tuple[dict, np.ndarray]:
    """The elements of a model with stiction whose drop (theta < 1: the force falls at the slip amplitude phi_max,
    ``nonlinear.modal_joint.slip_amplitudes``) sits on a measured level (``levels_on_drops``: where a fit's optimum
    puts it, moving the drop across that level jumps the residuals), and what the points tell of phi_max: only
    that it lies between that level and the next one on its stuck side (none past the measured range). Returns
    (element name -> the reason, in words; rows (d, p) to stack under the Jacobian, one per closed gap: the gradient
    of ln phi_max over the variables divided by the standard deviation of ln phi_max uniform over the gap,
    ln(upper / lower) / sqrt(12)). ``vector`` (p,) of the variables of ``specification``; ``amplitude`` (n,)
    increasing."""
    amplitude = np.asarray(amplitude, dtype=float)
    on_drops = levels_on_drops(vector, specification, amplitude, nominal_frequency_hz)
    if not on_drops:
        return {}, np.zeros((0, len(vector)))
    slip = np.exp(log_slip_amplitudes(np.asarray(vector)[None], specification, nominal_frequency_hz)[0])
    gradient = forward_difference_jacobian(
        lambda rows: log_slip_amplitudes(rows, specification, nominal_frequency_hz), vector)  # (elements, p)
    reasons, rows = {}, []
    for element, level in on_drops.items():
        other = level - 1 if amplitude[level] >= slip[element] else level + 1
        where = f"its stiction drop sits on the level at amplitude {amplitude[level]:.4g}"
        name = ELEMENTS[element][0]
        if not 0 <= other < amplitude.size:
            reasons[name] = f"{where}, the last on its side: the points bound its slip amplitude on one side only"
            continue
        lower, upper = sorted((amplitude[level], amplitude[other]))
        reasons[name] = (f"{where}: the points place its slip amplitude only between {lower:.4g} and {upper:.4g} "
                         f"(uniform there in the covariance)")
        rows.append(gradient[element] / (np.log(upper / lower) / np.sqrt(12.0)))
    return reasons, np.array(rows).reshape(len(rows), len(vector))


def along_levels(residuals, vector, specification, nominal_frequency_hz: float, on_drops: dict, held: dict):
    """The least-squares optimum of ``residuals`` (rows of variables (b, p) -> residuals (b, m)) from ``vector``
    (p,) with the slip amplitude of each element of ``on_drops`` (``levels_on_drops``) kept at its value there, on
    its level's side of the drop (each element's log slip force set by the others: phi_max is proportional to it),
    and the variables of ``held`` (index -> value) held: where a fit's optimum sits on a drop it is the smooth
    problem's optimum on that boundary, which the free least squares only creep towards (a drop pulled across the
    level jumps the residuals). Returns ``best_least_squares``'s (chi^2, vector, Jacobian, converged), the vector
    with the slip forces so set and the Jacobian that of the free variables' forward differences."""
    elements = list(on_drops)
    indices = [next(i for i, (name, _, _) in enumerate(specification)
                    if name == "slip_force" + ELEMENTS[element][1]) for element in elements]
    target = log_slip_amplitudes(np.asarray(vector)[None], specification, nominal_frequency_hz)[0, elements]

    def pinned(rows):
        rows = np.array(rows, dtype=float)
        rows[..., indices] += target - log_slip_amplitudes(rows.reshape(-1, rows.shape[-1]), specification,
                                                           nominal_frequency_hz)[:, elements].reshape(
                                                               *rows.shape[:-1], len(elements))
        return rows

    chi_squared, found, _, converged = best_least_squares(lambda rows: residuals(pinned(rows)), [vector],
                                                          {**held, **{index: vector[index] for index in indices}})
    found = pinned(found)
    jacobian = forward_difference_jacobian(residuals, found)
    jacobian[:, list(held)] = 0.0
    return chi_squared, found, jacobian, converged


def unresolved_effects(measurement: BackboneLevels, effects, parameters: dict, backbone, model) -> dict:
    """Effect -> reason for the ``effects`` whose own change of a fitted model is below the measurement's
    resolution: switched off (its parameters removed from ``parameters``, the others as fitted; ``model(values)``
    gives the frequency (Hz) and damping (n,) at the measured levels), the model's ``backbone`` (frequency,
    damping) moves at no level by its standard uncertainty (``sigma_frequency``, ``sigma_damping``). Many levels
    together can weigh such a change beyond ``EVIDENCE``, but it is a shape no level resolves, and the one-mode
    law's own form error is of that size: on clean challenge-like ring-downs with the key's nominal a stiffness
    change of 7e-5 of the frequency (0.7 of the 1e-4 floor) lowered the BIC by 12."""
    reasons = {}
    for effect in effects:
        names = {name for name, _, _ in EFFECTS[effect].parameters}
        if not names & set(parameters):
            continue
        frequency, damping = model({name: value for name, value in parameters.items() if name not in names})
        change = max(float(np.max(np.abs(backbone[0] - frequency) / measurement.sigma_frequency)),
                     float(np.max(np.abs(backbone[1] - damping) / measurement.sigma_damping)))
        if change < 1.0:
            reasons[effect] = f"below the resolution (it moves no level by its uncertainty: at most {change:.2g} of it)"
    return reasons


def nominal_priors(effects, nominal_frequency_hz: float, nominal_damping: float,
                   nominal_uncertainty: tuple[float, float]) -> list:
    """The nominal's variables fitted under a prior (``fit``): ((name, kind, start), prior residual of the
    parameters) for the frequency shift and the linear damping where the nominal's standard error is positive and
    no effect of ``effects`` frees the parameter."""
    freed = {name for effect in effects for name, _, _ in EFFECTS[effect].parameters}
    error_frequency, error_damping = nominal_uncertainty
    priors = []
    if error_frequency > 0 and "frequency_shift" not in freed:
        priors.append((("frequency_shift", "shift", 0.0),
                       lambda p: p["frequency_shift"] * nominal_frequency_hz / error_frequency))
    if error_damping > 0 and "zeta_0" not in freed:
        priors.append((("zeta_0", "log", max(nominal_damping, ZETA_START)),
                       lambda p: (p["zeta_0"] - nominal_damping) / error_damping))
    return priors


def model_variables(effects) -> list:
    """The fitted variables of the one-mode model with ``effects``: (name, kind, start) of the joint, then of each
    effect in order."""
    return list(BASE) + [p for effect in effects for p in EFFECTS[effect].parameters]


def parameter_covariance(jacobian, chi_squared: float, dof: int, bounds=()) -> np.ndarray:
    """Covariance (p, p) of a weighted least-squares optimum's variables, V S^-2 V^T from the singular values S and
    right singular vectors V of J (m, p), the Jacobian of the residuals in units of the measurement's uncertainty,
    its singular values floored at ``SINGULAR_FLOOR`` of J's largest entry (a direction the points do not see gets
    a huge variance, as in ``determinacy``; a held variable's zero column gives it zero variance), scaled by
    chi^2 per degree of freedom where that exceeds 1 (a residual beyond the stated noise widens it, never
    narrows it). ``bounds``: rows (d, p) of what the points tell besides their residuals (``stiction_drops``),
    stacked under J scaled by that factor, not scaled themselves."""
    jacobian = np.asarray(jacobian, dtype=float)
    scale = max(1.0, chi_squared / max(dof, 1))
    if len(bounds):
        jacobian, scale = np.vstack([jacobian / np.sqrt(scale), bounds]), 1.0
    free = np.any(jacobian != 0.0, axis=0)
    covariance = np.zeros((jacobian.shape[1], jacobian.shape[1]))
    if not free.any():
        return covariance
    _, singular, rows = np.linalg.svd(jacobian[:, free], full_matrices=False)
    floor = max(SINGULAR_FLOOR * float(np.max(np.abs(jacobian))), np.finfo(float).tiny)
    covariance[np.ix_(free, free)] = (rows.T / np.maximum(singular, floor) ** 2) @ rows
    return covariance * scale


def bic(chi_squared: float, n_parameters: int, n_residuals: int) -> float:
    """Bayesian information criterion of a weighted least-squares fit: chi^2 + k ln n."""
    return chi_squared + n_parameters * np.log(n_residuals)


def slip_starts(measurement: BackboneLevels, nominal_frequency_hz: float, kappas, suffix: str = "") -> list[dict]:
    """Starts of an element's stiffness share ``kappa{suffix}`` and slip force ``slip_force{suffix}``: each share
    of ``kappas`` with the slip forces that put macroslip at four amplitudes from the lowest measured to three
    times the highest."""
    omega_squared = (2 * np.pi * nominal_frequency_hz) ** 2
    return [{f"kappa{suffix}": kappa, f"slip_force{suffix}": kappa * omega_squared * amplitude} for kappa in kappas
            for amplitude in np.geomspace(measurement.amplitude[0], measurement.amplitude[-1] * 3, 4)]


def base_starts(measurement: BackboneLevels, nominal_frequency_hz: float) -> list[dict]:
    """Starts of the reference fit: joint stiffness shares and slip forces that put macroslip across the
    measured amplitudes."""
    return slip_starts(measurement, nominal_frequency_hz, (0.02, 0.1, 0.4))


def with_stage_starts(starts: list[dict], measurement: BackboneLevels, nominal_frequency_hz: float) -> list[dict]:
    """Starts of a fit with the second slip stage from ``starts`` without it: the first (the previous model's
    optimum) with the stage slipping at each of four amplitudes across the measured range (``slip_starts``), the
    others with it slipping in the range's middle."""
    stages = slip_starts(measurement, nominal_frequency_hz, (EFFECTS[SECOND_STAGE].parameters[0][2],), STAGE_SUFFIX)
    middle = stages[len(stages) // 2]
    first = [starts[0]] if "kappa" + STAGE_SUFFIX in starts[0] else [{**stage, **starts[0]} for stage in stages]
    return first + [{**middle, **start} for start in starts[1:]]


def residual_features(measurement: BackboneLevels, model: Fit) -> dict:
    """Features of a fit's residual (measurement minus model) of frequency and damping, each in units of the
    measurement's uncertainty: offset (mean over the three lowest levels), slope and curvature of a quadratic in
    log amplitude (per decade, per decade squared), sign changes along the amplitude, and the largest kink (second
    difference). The signatures the effects leave: an offset (stiffness change, linear damping), a slope or
    curvature (amplitude damping, cubic stiffening), a kink (macroslip against microslip, stiction)."""
    decades = np.log10(measurement.amplitude / measurement.amplitude[0])
    features = {}
    for name, measured, modelled, sigma in (
            ("frequency", measurement.frequency_hz, model.frequency_hz, measurement.sigma_frequency),
            ("damping", measurement.damping, model.damping, measurement.sigma_damping)):
        residual = (measured - modelled) / sigma
        curvature, slope, _ = np.polyfit(decades, residual, 2)
        features[name] = {"offset": float(np.mean(residual[:3])), "slope_per_decade": float(slope),
                          "curvature_per_decade2": float(curvature),
                          "sign_changes": int(np.count_nonzero(np.diff(np.sign(residual)) != 0)),
                          "largest_kink": float(np.max(np.abs(np.diff(residual, 2)))) if residual.size > 2 else 0.0}
    return features


class Step(NamedTuple):
    """One step of the loop: the effect added (None for the reference model), the fit, its errors (L-infinity
    and RMS of frequency in Hz and of damping), chi^2 per degree of freedom, every candidate's BIC, and the
    candidates not accepted whatever their BIC, with the reason (``admissible``)."""

    effect: str | None
    fit: Fit
    errors: dict
    reduced_chi_squared: float
    candidates: dict
    rejected: dict = {}


@dataclass
class Verdict:
    """The loop's answer: the effects found in order, the steps with their evidence, the findings of the signal
    checks beside the backbone (``experiment.signal_checks``; :func:`with_findings`), whether something remains
    unexplained (a residual above the noise, or a finding outside the library), the final fit, the other
    models the selection cannot tell from it (``alternatives``: effects -> BIC, the other answers of
    ``final_model``), the models it evaluated that fit better by more than ``EVIDENCE`` but cannot be accepted
    (``better_not_accepted``: effects -> their BIC and the reasons, ``admissible``), and every model it fitted
    (``evaluated``: effects -> its BIC, chi^2, number of parameters and the reasons it cannot be accepted, empty
    where it can)."""

    effects: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    unexplained: bool = False
    findings: list = field(default_factory=list)
    final: Fit | None = None
    alternatives: dict = field(default_factory=dict)
    better_not_accepted: dict = field(default_factory=dict)
    evaluated: dict = field(default_factory=dict)

    @property
    def joint_law(self) -> list:
        """The effects found that belong to the joint's friction law (``discrepancy.effects``)."""
        return [effect for effect in self.effects if EFFECTS[effect].in_joint]

    @property
    def added(self) -> list:
        """The effects found outside the joint: what the structure's model lacks besides the joint's law."""
        return [effect for effect in self.effects if not EFFECTS[effect].in_joint]


def with_findings(verdict: Verdict, findings: list) -> Verdict:
    """The verdict with the findings of the ring-down's signal checks (``experiment.signal_checks``: JSON-ready
    dicts with ``name``, ``outside_library``, ``summary``, ``evidence``): one outside any backbone library (a
    second mode, a drift, clipping) makes it unexplained whatever the backbone's residual, since no effect fitted
    to the backbone can stand for it; the others (no pre-trigger, a truncated record) are named beside it."""
    return replace(verdict, findings=list(findings),
                   unexplained=verdict.unexplained or any(entry["outside_library"] for entry in findings))


def errors(measurement: BackboneLevels, model: Fit) -> dict:
    """L-infinity and RMS errors of frequency (Hz) and damping of a fit."""
    frequency, damping = model.frequency_hz - measurement.frequency_hz, model.damping - measurement.damping
    return {"frequency_linf_hz": float(np.max(np.abs(frequency))), "frequency_rms_hz": float(np.sqrt(np.mean(frequency ** 2))),
            "damping_linf": float(np.max(np.abs(damping))), "damping_rms": float(np.sqrt(np.mean(damping ** 2)))}


def discrepancy_loop(measurement: BackboneLevels, nominal_frequency_hz: float, nominal_damping: float,
                     library=ONE_MODE_EFFECTS, nominal_uncertainty: tuple[float, float] = (0.0, 0.0)) -> Verdict:
    """Run the loop (module docstring) on ``measurement`` from the reference model: forward selection by BIC,
    then a stepwise check that no effect found can be swapped for another or dropped at a lower BIC (greedy
    forward steps can take a look-alike first when two effects are in the data). ``nominal_uncertainty``: the
    standard errors (Hz, -) of a nominal estimated from the measurement itself (``discrepancy.nominal``; 0 for a
    nominal given), fitted under their prior (``fit``)."""
    starts = base_starts(measurement, nominal_frequency_hz)

    def fitted(effects, previous=None, again=False):
        trial_starts = (([dict(previous.parameters)] if previous is not None else [])
                        + ([] if again else [dict(s) for s in starts]))
        if SECOND_STAGE in effects:
            trial_starts = with_stage_starts(trial_starts, measurement, nominal_frequency_hz)
        return fit(measurement, tuple(effects), nominal_frequency_hz, nominal_damping, trial_starts,
                   nominal_uncertainty)

    def restarted(model):
        if "chi" not in model.parameters:
            return None
        return fit(measurement, model.effects, nominal_frequency_hz, nominal_damping, shape_starts(model.parameters),
                   nominal_uncertainty)

    return select_effects(measurement, fitted, library, restarted)


def shape_starts(parameters: dict) -> list[dict]:
    """Starts of a fit with Iwan's law from its optimum ``parameters``: the optimum, then the optimum with each
    shape (chi, beta) of ``SHAPES``. Every start of the loop's own has the library's chi = -0.5, beta = 0.1, and the
    optimum a fit reaches hangs on them: on the measured ASB C3 the final model ended with beta held at 0 (BIC
    79.44), where its free optimum, reached from other shapes, is at beta 0.21 (BIC 78.94)."""
    return [dict(parameters)] + [{**parameters, "chi": chi, "beta": beta} for chi, beta in SHAPES]


def select_effects(measurement: BackboneLevels, fitted, library, restarted=None) -> Verdict:
    """The loop's decisions, for any model family: ``fitted(effects, previous, again)`` gives the best Fit of the
    reference model with ``effects`` added (None where the family cannot hold that combination; a Fit whose
    effects hold more where an effect comes only with another, as a stuck core with microslip on a superelement:
    the step names both), starting from ``previous`` and, unless ``again`` (the model was fitted before from them),
    from the family's own starts. Forward selection by BIC from the reference model, forward paths from the
    next-best first steps (``other_first_steps``, ``climb``), then ``stepwise_refinement``; the answer is
    ``final_model`` over every model they evaluated, once each model has been fitted from the optima of the models
    one effect larger and smaller that could make it a candidate (``refit_nested``) and each candidate answer from
    the family's further starts (``restarted(fit)``: a Fit, or None where it has none; ``restart_candidates``)."""
    n = 2 * len(measurement.amplitude)
    evaluated = {}  # effects (frozenset) -> the best Fit found of them, or None
    tried = set()  # (effects, the start's effects, its chi^2): the starts each model was fitted from again
    reference = {}  # the reference model's errors (``errors``), once it is fitted

    def accepted(model):
        return model is not None and not admissible(measurement, model, reference, model.effects)

    def improves(found: Fit, known: Fit) -> bool:
        return accepted(found) if accepted(found) != accepted(known) else found.bic < known.bic - SETTLED

    def trial(effects, previous=None):
        """The model with ``effects``, fitted once from ``previous`` and the family's starts, and again from each
        other ``previous`` it is given (a start it did not have, each once) that is one effect larger or smaller,
        whatever its chi^2 (on challenge P6 with the nominal estimated, microslip, a second stage and a stiffness
        change reached chi^2 23.0 from a second stage with a stiffness change at 888, and 34.3 from microslip with
        a second stage at 36.5), or any other model that fits the data better; it replaces the fit where it is
        accepted and the fit is not, or, as acceptable, lowers the BIC by more than ``SETTLED`` (on the measured
        ASB C2 a stiction, a stiffness change, a cubic and a linear damping refitted from a model with a second
        stage went from BIC 188.7 to 179.7 with theta undetermined; a refit can find a free optimum with a lower
        chi^2 where the first fit held a parameter at its law's limit at a lower BIC: the measured ASB C4a's
        microslip, beta held, BIC 57.35, refitted free at 57.54). Where it holds effects below the resolution
        (``Fit.unresolved``), the model without them is fitted from it too: it is that model to within the noise,
        a start the smaller model's own may miss (a stiction alone ended at chi^2/dof 278 where stiction with a
        stiffness change of 2 % of an uncertainty reached 0.62)."""
        key = frozenset(effects)
        start = None if previous is None else (key, frozenset(previous.effects), previous.chi_squared)
        if key not in evaluated:
            evaluated[key] = fitted(tuple(effects), previous)
            tried.add(start)
        elif (known := evaluated[key]) is not None and start is not None and start not in tried and (
                len(key ^ start[1]) == 1 or previous.chi_squared < known.chi_squared):
            tried.add(start)
            found = fitted(tuple(effects), previous, True)
            if found is not None and improves(found, known):
                evaluated[key] = found
        found = evaluated[key]
        if found is not None and found.unresolved:
            trial(tuple(effect for effect in effects if effect not in found.unresolved), found)
        return found

    def step(effect, model, candidates, rejected=None):
        return Step(effect, model, errors(measurement, model), model.chi_squared / max(n - model.n_parameters, 1),
                    candidates, rejected or {})

    current = trial(())
    verdict = Verdict(steps=[step(None, current, {})])
    reference.update(verdict.steps[0].errors)
    while verdict.steps[-1].reduced_chi_squared > AT_NOISE:
        trials = {effect: trial((*current.effects, effect), current) for effect in library
                  if effect not in current.effects}
        trials = {effect: model for effect, model in trials.items() if model is not None}
        if not trials:
            break
        candidates = {effect: model.bic for effect, model in trials.items()}
        rejected = {effect: "; ".join(reasons) for effect, model in trials.items()
                    if (reasons := admissible(measurement, model, reference, (effect,)))}
        eligible = [effect for effect in trials if effect not in rejected]
        best = min(eligible, key=lambda e: trials[e].bic) if eligible else None
        if best is None or trials[best].bic > current.bic - EVIDENCE:
            verdict.steps[-1] = verdict.steps[-1]._replace(candidates=candidates, rejected=rejected)
            break
        added = [effect for effect in trials[best].effects if effect not in current.effects]  # with what it brings
        current = trials[best]
        verdict.steps.append(step(", ".join(added), current, candidates, rejected))
    climbed = set()
    for model in other_first_steps(verdict.steps[0].fit, current, evaluated, accepted):
        climb(model, library, trial, accepted, climbed)
    stepwise_refinement(current, library, trial, accepted)
    refit_nested(evaluated, trial, accepted)
    if restarted is not None:
        restart_candidates(evaluated, restarted, accepted, improves, lambda: refit_nested(evaluated, trial, accepted))
    final, verdict.alternatives = final_model([model for model in evaluated.values() if accepted(model)])
    if final is not current:
        verdict.steps.append(step("selected: " + (", ".join(final.effects) or "the reference"), final,
                                  {"before refinement": current.bic}))
    verdict.final = final
    verdict.evaluated = {", ".join(sorted(model.effects)): {  # of the same effects reached twice, the lower BIC
        "bic": model.bic, "chi_squared": model.chi_squared, "parameters": model.n_parameters,
        "not_accepted": admissible(measurement, model, reference, model.effects)}
        for model in sorted((model for model in evaluated.values() if model is not None), key=lambda m: -m.bic)}
    verdict.better_not_accepted = {effects: f"BIC {entry['bic']:.4g}: " + "; ".join(entry["not_accepted"])
                                   for effects, entry in verdict.evaluated.items()
                                   if entry["bic"] < final.bic - EVIDENCE and entry["not_accepted"]}
    verdict.effects = list(final.effects)
    verdict.unexplained = verdict.steps[-1].reduced_chi_squared > UNEXPLAINED
    return verdict


def other_first_steps(reference: Fit, current: Fit, evaluated: dict, accepted) -> list:
    """The single-effect models other than the forward path's first that earn their parameter over the reference
    (accepted, BIC lower by ``EVIDENCE``), the ``OTHER_PATHS`` best by BIC: where the greedy path's first step
    was a look-alike, a path from one of them can reach a better model (``climb``)."""
    first = set(current.effects[:1])
    singles = [model for key, model in evaluated.items() if len(key) == 1 and not key & first and accepted(model)
               and model.bic < reference.bic - EVIDENCE]
    return sorted(singles, key=lambda model: model.bic)[:OTHER_PATHS]


def climb(model: Fit, library, trial, accepted, climbed: set, branches: int = BRANCHES) -> None:
    """Forward selection from ``model``: add the accepted effect with the lowest BIC while it lowers the BIC by
    more than ``EVIDENCE``, past the noise too (``AT_NOISE`` stops only the greedy path: a path can pass a model at
    the noise on its way to a better one, as a challenge-like mass loading with a cubic stiffening whose amplitude
    damping stopped at chi^2/dof 1.34, BIC 63.1, where the cubic reaches 38.9); at the first step, each of the
    ``branches`` best such effects in turn (a greedy path can take a look-alike there: on the ASB C4 one-mode
    backbone a second slip stage after the cubic stiffening blocked the microslip, stiction and stiffness change
    that fit better). ``climbed``: the effect sets already climbed from (each once); every fit lands among those
    ``final_model`` chooses from."""
    key = frozenset(model.effects)
    if key in climbed:
        return
    climbed.add(key)
    trials = [trial((*model.effects, effect), model) for effect in library if effect not in model.effects]
    better = sorted((found for found in trials if accepted(found) and found.bic < model.bic - EVIDENCE),
                    key=lambda found: found.bic)
    for found in better[:branches]:
        climb(found, library, trial, accepted, climbed, 1)


def refit_nested(evaluated: dict, trial, accepted) -> None:
    """Fit the models of ``evaluated`` (effects -> Fit or None) again from the optima of the models one effect
    larger and smaller that fit better than they do (``trial(effects, previous)``: each start once, the refit
    replacing the fit by ``select_effects``'s rule) until no fit moves. A model holds every model one
    effect smaller (that effect switched off): its optimum, without that effect's parameters, is a start the
    smaller model's own may miss, and the smaller model's optimum is a start of the larger one, which must not end
    worse than a model it holds. Without this the optimum a fit reaches depends on the path that first reached the
    model, and so can the answer (a challenge-like cubic stiffening, the nominal estimated: microslip, a second
    stage and the cubic ended at BIC 50.4 from their own starts and at 38.2 from the optimum that also held an
    amplitude damping, which had been the answer at 39.7). A start is used where it could make the model a
    candidate answer (its BIC with the start's chi^2 within ``EVIDENCE`` of the lowest accepted BIC), and every
    model one effect smaller than a candidate (an accepted fit within ``EVIDENCE`` of the lowest: the set
    ``final_model`` chooses from) is fitted, evaluated before or not."""
    while True:
        before = {key: id(model) for key, model in evaluated.items()}
        fits = sorted(((key, model) for key, model in evaluated.items() if model is not None),
                      key=lambda item: (item[1].bic, sorted(item[0])))
        lowest = min(model.bic for _, model in fits if accepted(model))
        for key, larger in fits:
            candidate = accepted(larger) and larger.bic <= lowest + EVIDENCE
            for effect in sorted(key):
                smaller = key - {effect}
                inner = evaluated.get(smaller)
                if inner is None:
                    if candidate and smaller not in evaluated:
                        trial(in_order(smaller, larger), larger)
                elif larger.chi_squared < inner.chi_squared:
                    if inner.bic - inner.chi_squared + larger.chi_squared <= lowest + EVIDENCE:
                        trial(in_order(smaller, larger), larger)
                elif larger.bic - larger.chi_squared + inner.chi_squared <= lowest + EVIDENCE:
                    trial(in_order(key, larger), inner)
        if {key: id(model) for key, model in evaluated.items()} == before:
            return


def restart_candidates(evaluated: dict, restarted, accepted, improves, refit) -> None:
    """Fit each candidate answer of ``evaluated`` (effects -> Fit or None; a candidate: an accepted fit within
    ``EVIDENCE`` of the lowest accepted BIC) again from the family's further starts, ``restarted(fit)`` (a Fit, or
    None where the family has none for it: starts too many to try on every model the loop fits), the refit
    replacing the fit where ``improves(refit, fit)``; where one does, ``refit()`` fits the models around it again
    from the optimum that moved (``refit_nested``), until every candidate has been restarted from its own optimum."""
    restarted_from = set()  # (effects, chi^2): the optima a model was restarted from
    while True:
        lowest = min(model.bic for model in evaluated.values() if accepted(model))
        candidates = [(key, model) for key, model in evaluated.items() if accepted(model)
                      and model.bic <= lowest + EVIDENCE and (key, model.chi_squared) not in restarted_from]
        if not candidates:
            return
        moved = False
        for key, model in candidates:
            restarted_from.add((key, model.chi_squared))
            found = restarted(model)
            if found is not None and improves(found, model):
                evaluated[key], moved = found, True
        if moved:
            refit()


def in_order(effects: frozenset, model: Fit) -> tuple:
    """``effects`` in the order ``model`` holds them (a model's effects keep the order they were added in)."""
    return tuple(effect for effect in model.effects if effect in effects)


def final_model(accepted: list) -> tuple:
    """The answer among the ``accepted`` fits (every model the loop evaluated that meets ``admissible``). Of the
    fits whose BIC is within ``EVIDENCE`` of the lowest (models the data do not tell apart from the best), those
    that hold none of the others are the answers: a richer model within ``EVIDENCE`` of one it holds has not earned
    the parameters of its further effects (eight points of microslip with a linear damping, chi^2/dof 2.16 by their
    noise: a second slip stage below the lowest point reaches 1.45 at a BIC 5.2 lower). Of these, which are other
    explanations of the data and not one the other's with more, the one with the lowest BIC (then the fewest
    parameters): parsimony is already in the BIC, and a model with more parameters but not more effects of the other
    is no richer version of it (a challenge-like linear damping with a cubic stiffening, the key's nominal:
    microslip with a linear and an amplitude damping, 5 parameters, BIC 50.1, against microslip, a second slip stage,
    the linear damping and the cubic, 7 parameters, 43.5; the fewest parameters named the amplitude damping and
    not the cubic). Returns (that Fit, {effects: BIC} of the other answers: the selection cannot tell them from it).
    The loop therefore never ends on a model worse by its own criterion than one it evaluated and could accept,
    whether or not a simpler one reaches the noise: the fit's floors (``study.structures.FREQUENCY_FLOOR``,
    ``DAMPING_FLOOR``) stand above FreeVib's standard errors at most levels, so a model that misses a systematic
    trend can reach chi^2 per degree of freedom ``AT_NOISE``."""
    lowest = min(model.bic for model in accepted)
    near = [model for model in accepted if model.bic <= lowest + EVIDENCE]
    answers = [model for model in near if not any(set(other.effects) < set(model.effects) for other in near)]
    final = min(answers, key=lambda model: (model.bic, model.n_parameters))
    return final, {", ".join(sorted(model.effects)): model.bic for model in answers
                   if set(model.effects) != set(final.effects)}


def flagged(trial: Fit, effects) -> list[str]:
    """The reasons ``trial`` gives for parameters of ``effects`` at a bound or undetermined, and for effects below
    the resolution (an effect that lives in a friction model's design, as the superelement route's stuck core, has
    no parameter of the library)."""
    return [f"{name} {trial.undetermined[name]}" for effect in effects
            for name, _, _ in EFFECTS[effect].parameters if name in trial.undetermined] + [
        f"{effect} {trial.unresolved[effect]}" for effect in effects if effect in trial.unresolved]


def admissible(measurement: BackboneLevels, trial: Fit, reference: dict, effects) -> list[str]:
    """Why a trial fit cannot be accepted whatever its BIC (empty if it can): parameters of ``effects`` at a
    bound or undetermined, or an L-infinity error worse than the reference model's (``reference``: its
    ``errors``) by more than the measurement's largest standard uncertainty (module docstring)."""
    reasons = flagged(trial, effects)
    found = errors(measurement, trial)
    for name, key, sigma in (("frequency", "frequency_linf_hz", measurement.sigma_frequency),
                             ("damping", "damping_linf", measurement.sigma_damping)):
        if found[key] > reference[key] + float(np.max(sigma)):
            reasons.append(f"L-infinity {name} error {found[key]:.3g} above the reference's {reference[key]:.3g}")
    return reasons


def stepwise_refinement(current: Fit, library, fitted, accepted) -> None:
    """Explore around the forward selection's model: swap an effect for one outside it, or drop one, while that
    gives an accepted fit (``accepted``: ``admissible`` for all its effects) with a lower BIC (dropping: a BIC
    that rises by less than EVIDENCE, the effect not earning its parameters). Greedy forward steps can take a
    look-alike first when two effects are in the data; every fit tried here is among those ``final_model``
    chooses from."""
    improved, visited = True, {frozenset(current.effects)}
    while improved and current.effects:
        improved = False
        for effect in current.effects:
            others = tuple(e for e in current.effects if e != effect)
            dropped = fitted(others, current)
            if accepted(dropped) and dropped.bic < current.bic + EVIDENCE and frozenset(others) not in visited:
                current, improved = dropped, True
                visited.add(frozenset(others))
                break
            swaps = [fitted((*others, candidate), current) for candidate in library if candidate not in current.effects]
            better = [trial for trial in swaps if accepted(trial) and trial.bic < current.bic - 1e-9]
            if better:
                current, improved = min(better, key=lambda trial: trial.bic), True
                visited.add(frozenset(current.effects))
                break
