"""Whole-joint elements between patch pairs and the four friction models of paper Table 2.

Each patch pair p carries, on the relative virtual-node translation (top minus bottom), a friction element in
each tangential direction x and y (same parameters in both) and a linear spring K_z in the normal direction.
Patches share parameters by symmetry group (``patch_groups``, one group index per patch; the BRB's five
patches form groups {1, 5}, {2, 4}, {3}). A design is one vector of group parameters, concatenated group by
group in this order:

    jenkins        (F_S, K_T, K_z)                     3 per group  (BRB: 9)
    iwan4          (F_S, K_T, chi, beta, K_z)          5 per group  (BRB: 15)
    iwan5          (F_S, K_T, chi, beta, theta, K_z)   6 per group  (BRB: 18)
    iwan4_stuck    iwan4 groups, but the ``stuck_group`` (the BRB's middle patch 3, the last group by
                   default) is linear: (K_T, K_z)      (BRB: 5 + 5 + 2 = 12)

Convention: parameters are per patch pair, in N and N/m, not scaled by patch area (the authors' code scaled
F_S, K_T and K_z by the patch area; Table 3's limits are then per m^2). Units: forces N, displacements m.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear import iwan, slip_laws
from nonlinear.parameters import FrictionParameterError, check_iwan, check_jenkins, check_positive

GROUP_PARAMETERS = {
    "jenkins": ("F_S", "K_T", "K_z"),
    "iwan4": ("F_S", "K_T", "chi", "beta", "K_z"),
    "iwan5": ("F_S", "K_T", "chi", "beta", "theta", "K_z"),
    "iwan4_stuck": ("F_S", "K_T", "chi", "beta", "K_z"),
}
STUCK_GROUP_PARAMETERS = ("K_T", "K_z")
# Paper Table 3: (minimum, maximum, logarithmic sampling) of each parameter.
TABLE3_LIMITS = {
    "F_S": (1e1, 1e11, True), "K_T": (1e2, 1e14, True), "chi": (-0.99, -0.01, False),
    "beta": (1e-4, 1e4, True), "theta": (0.0, 1.0, False), "K_z": (1e2, 1e14, True),
}
FRICTION_MODELS = tuple(GROUP_PARAMETERS)
BRB_PATCH_GROUPS = (0, 1, 2, 1, 0)


class ScaledLaw(NamedTuple):
    """Element constants of the scaled slip law (``nonlinear.slip_laws``), arrays like the parameters:
    phi_max (m, the scale of the slip; 1 for stuck patches), r and s (N), chi, theta."""

    phi_max: np.ndarray
    r: np.ndarray
    s: np.ndarray
    chi: np.ndarray
    theta: np.ndarray


class PatchElements(NamedTuple):
    """Element parameters of every patch for a batch of designs; arrays of shape (n_designs, n_patches).

    law: "jenkins", "iwan4" or "iwan5" (the law of the friction elements); stuck: (n_patches,) bool, patches
    whose tangential elements are linear springs K_T. Unused entries (chi for Jenkins, F_S of a stuck patch)
    hold values that make the laws well defined and are never read for those patches.
    """

    law: str
    slip_force: np.ndarray
    stiffness: np.ndarray
    chi: np.ndarray
    beta: np.ndarray
    theta: np.ndarray
    normal_stiffness: np.ndarray
    stuck: np.ndarray


def parameter_names(model: str, n_groups: int, stuck_group: int | None = None) -> list[str]:
    """Names of the design vector's entries, e.g. 'F_S[0]' (group index in brackets)."""
    _check_model(model)
    stuck_group = _stuck_group(model, n_groups, stuck_group)
    names = []
    for group in range(n_groups):
        group_names = STUCK_GROUP_PARAMETERS if group == stuck_group else GROUP_PARAMETERS[model]
        names += [f"{name}[{group}]" for name in group_names]
    return names


def parameter_limits(model: str, n_groups: int, stuck_group: int | None = None):
    """Table 3 limits of the model's design vector: lower (d,), upper (d,), logarithmic (d,) bool."""
    names = [name.split("[")[0] for name in parameter_names(model, n_groups, stuck_group)]
    lower, upper, logarithmic = (np.array([TABLE3_LIMITS[name][i] for name in names]) for i in range(3))
    return lower.astype(float), upper.astype(float), logarithmic.astype(bool)


def from_unit(unit, lower, upper, logarithmic) -> np.ndarray:
    """Parameters (n, d) of unit designs (n, d) in [0, 1]: p = lo + u (hi - lo), in log p where Table 3
    samples logarithmically."""
    low, high = _sampling_scale(lower, logarithmic), _sampling_scale(upper, logarithmic)
    values = low + np.asarray(unit, dtype=float) * (high - low)
    return np.where(logarithmic, np.exp(values), values)


def to_unit(designs, lower, upper, logarithmic) -> np.ndarray:
    """Unit designs (n, d) of parameters (n, d): the inverse of :func:`from_unit`."""
    low, high = _sampling_scale(lower, logarithmic), _sampling_scale(upper, logarithmic)
    return (_sampling_scale(designs, logarithmic) - low) / (high - low)


def _sampling_scale(values, logarithmic) -> np.ndarray:
    """Values on the scale Table 3 samples them: log where ``logarithmic``, else unchanged."""
    values = np.asarray(values, dtype=float)
    return np.where(logarithmic, np.log(np.where(logarithmic, values, 1.0)), values)


def random_designs(model: str, n_designs: int, n_groups: int, rng: np.random.Generator,
                   stuck_group: int | None = None) -> np.ndarray:
    """Designs drawn uniformly (in log where Table 3 says so) within the paper's Table 3 limits,
    (n_designs, n_parameters). For test and benchmark samples; the study stage uses Latin hypercubes."""
    lower, upper, logarithmic = parameter_limits(model, n_groups, stuck_group)
    return from_unit(rng.random((n_designs, len(lower))), lower, upper, logarithmic)


def patch_elements(model: str, designs, patch_groups=BRB_PATCH_GROUPS, stuck_group: int | None = None
                   ) -> PatchElements:
    """Map design vectors (n_designs, n_parameters) or (n_parameters,) to per-patch element parameters.

    Raises FrictionParameterError for a wrong length or any parameter outside its physical range.
    """
    _check_model(model)
    groups = np.asarray(patch_groups, dtype=int)
    n_groups = int(groups.max()) + 1
    names = parameter_names(model, n_groups, stuck_group)
    designs = np.atleast_2d(np.asarray(designs, dtype=float))
    if designs.shape[1] != len(names):
        raise FrictionParameterError(
            f"model {model!r} with {n_groups} patch groups takes {len(names)} parameters {names}; "
            f"got {designs.shape[1]}")
    stuck_group = _stuck_group(model, n_groups, stuck_group)
    defaults = {"F_S": 1.0, "K_T": 1.0, "chi": -0.5, "beta": 0.0, "theta": 1.0, "K_z": 1.0}
    per_group = {name: np.tile(value, (designs.shape[0], n_groups)) for name, value in defaults.items()}
    column = 0
    for group in range(n_groups):
        group_names = STUCK_GROUP_PARAMETERS if group == stuck_group else GROUP_PARAMETERS[model]
        for name in group_names:
            per_group[name][:, group] = designs[:, column]
            column += 1
    law = {"jenkins": "jenkins", "iwan4": "iwan4", "iwan5": "iwan5", "iwan4_stuck": "iwan4"}[model]
    check_positive(per_group["K_z"], "normal stiffness K_z")
    if law == "jenkins":
        check_jenkins(per_group["K_T"], per_group["F_S"])
    else:
        check_iwan(per_group["F_S"], per_group["K_T"], per_group["chi"], per_group["beta"], per_group["theta"])
    stuck = groups == stuck_group
    return PatchElements(law, *(per_group[name][:, groups] for name in
                                ("F_S", "K_T", "chi", "beta", "theta", "K_z")), stuck)


def scaled_law(elements: PatchElements) -> ScaledLaw:
    """Constants of every element's slip law: Iwan by Segalman's mapping, Jenkins as r = 0, s = F_S,
    phi_max = F_S / K_T, stuck patches r = s = 0 (no slip)."""
    if elements.law == "jenkins":
        phi_max, s = elements.slip_force / elements.stiffness, elements.slip_force
        r = np.zeros_like(s)
    else:
        phi_max, r, s = iwan.segalman_constants(elements.slip_force, elements.stiffness, elements.chi, elements.beta)
    stuck = elements.stuck
    return ScaledLaw(np.where(stuck, 1.0, phi_max), np.where(stuck, 0.0, r), np.where(stuck, 0.0, s),
                     elements.chi, elements.theta)


def slip_displacement(elements: PatchElements) -> np.ndarray:
    """Displacement at which an element reaches macroslip (m), (n_designs, n_patches): F_S / K_T for Jenkins,
    phi_max for Iwan, +inf for stuck patches."""
    return np.where(elements.stuck, np.inf, scaled_law(elements).phi_max)


def tangential_tangent(elements: PatchElements, displacement) -> np.ndarray:
    """Tangent stiffness df/du = K_T - g'(u) (N/m) of the tangential elements, from the scaled slip law
    (``nonlinear.slip_laws.backbone_force_slope``): K_T at zero displacement, 0 beyond macroslip; K_T for
    stuck patches."""
    law = scaled_law(elements)
    tangent = slip_laws.backbone_force_slope(displacement / law.phi_max, law.r, law.s, law.chi, law.theta) / law.phi_max
    return np.where(elements.stuck, elements.stiffness, tangent)


def tangential_force(elements: PatchElements, displacement) -> np.ndarray:
    """Force f = K_T u - g(u) (N) of the tangential elements at displacement (m), their backbones (paper Eqs. 14,
    18, 21) from the scaled slip law (``nonlinear.slip_laws.backbone_force``): constant beyond macroslip (no
    K_T u - g cancellation there); K_T u for stuck patches."""
    law = scaled_law(elements)
    force = slip_laws.backbone_force(displacement / law.phi_max, law.r, law.s, law.chi, law.theta)
    return np.where(elements.stuck, elements.stiffness * displacement, force)


def tangential_slip_deficit(elements: PatchElements, displacement) -> np.ndarray:
    """Force lost to slip, K_T u - f(u) (N), of the tangential elements; zero for stuck patches."""
    law = scaled_law(elements)
    return slip_laws.slip_deficit(displacement / law.phi_max, law.r, law.s, law.chi, law.theta)


def tangential_slip_deficit_tangent(elements: PatchElements, displacement) -> np.ndarray:
    """Derivative of the slip deficit (N/m), between 0 (stuck) and K_T (macroslip); above K_T where a
    stiction backbone softens."""
    law = scaled_law(elements)
    return slip_laws.slip_deficit_slope(displacement / law.phi_max, law.r, law.s, law.chi, law.theta) / law.phi_max


def tangential_slip_deficit_potential(elements: PatchElements, displacement) -> np.ndarray:
    """Integral of the slip deficit from 0 to the displacement (J); zero for stuck patches. The static QSMA
    problem minimises a quadratic form minus the sum of these (convex for Jenkins and four-parameter Iwan)."""
    law = scaled_law(elements)
    return law.phi_max * slip_laws.slip_deficit_potential(displacement / law.phi_max, law.r, law.s, law.chi,
                                                          law.theta)


def tangential_dissipation(elements: PatchElements, amplitude) -> np.ndarray:
    """Masing cycle dissipation D = 4 phi_max (x g - 2 G) (J) of the tangential elements at amplitude (m), x the
    scaled amplitude (paper Eqs. 15, 19, 22; the QSMA kernel's formula), from the scaled slip law
    (``nonlinear.slip_laws.masing_dissipation``); zero for stuck patches."""
    law = scaled_law(elements)
    dissipation = 4.0 * law.phi_max * slip_laws.masing_dissipation(amplitude / law.phi_max, law.r, law.s, law.chi,
                                                                   law.theta)
    return np.where(elements.stuck, 0.0, dissipation)


def tangential_elements(elements: PatchElements) -> PatchElements:
    """The same elements listed once per tangential direction: arrays (n_designs, 2 n_patches) ordered
    (x, y) per patch, the order of the tangential joint unknowns."""
    return PatchElements(elements.law, *(np.repeat(a, 2, axis=-1) for a in elements[1:]))


def tangential_rows(n_patches: int) -> np.ndarray:
    """Rows of the tangential (x, y) translations among the 3 n_patches relative joint translations."""
    return (np.arange(n_patches)[:, None] * 3 + np.arange(2)).ravel()


def stuck_stiffness(elements: PatchElements) -> np.ndarray:
    """Initial tangents of all joint springs (N/m), (n_designs, 3 n_patches) ordered x, y, z per patch."""
    return np.stack([elements.stiffness, elements.stiffness, elements.normal_stiffness], axis=-1).reshape(
        elements.stiffness.shape[0], -1)


def _check_model(model: str) -> None:
    if model not in GROUP_PARAMETERS:
        raise FrictionParameterError(f"unknown friction model {model!r}; choose one of {FRICTION_MODELS}")


def _stuck_group(model: str, n_groups: int, stuck_group: int | None) -> int | None:
    if model != "iwan4_stuck":
        return None
    if n_groups < 2:
        raise FrictionParameterError("the middle-stuck model needs at least two patch groups")
    return n_groups - 1 if stuck_group is None else stuck_group
