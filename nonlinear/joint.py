"""Whole-joint elements between patch pairs and the four friction models of paper Table 2.

Each patch pair p carries, on the relative virtual-node translation (top minus bottom), a friction element in
each tangential direction x and y (same parameters in both) and a linear spring K_z in the normal direction.
Patches share parameters by symmetry group (``patch_groups``, one group index per patch; the BRB's five
patches form groups {1, 5}, {2, 4}, {3}). A design is one vector of group parameters, concatenated group by
group, in the order of its friction model (``nonlinear.friction_models``: jenkins, iwan4, iwan5, iwan4_stuck,
iwan4_core). A core spring K_c (iwan4_core) acts in parallel with each tangential element: it adds K_c u to the
element's force and K_c to its tangent, and nothing to its slip deficit or dissipation.

Convention: parameters are per patch pair, in N and N/m, not scaled by patch area (the authors' code scaled
F_S, K_T and K_z by the patch area; Table 3's limits are then per m^2). Units: forces N, displacements m.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear import slip_laws
from nonlinear.friction_models import (CONTAINED_UNIT, ELEMENT_DEFAULTS, ELEMENT_PARAMETERS, TABLE3_LIMITS,
                                       FrictionModel, friction_model)
from nonlinear.parameters import FrictionParameterError

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

    model: the friction model (``nonlinear.friction_models``); core_stiffness: K_c (N/m), the linear spring in
    parallel with each tangential element (0: none); stuck: (n_patches,) bool, patches whose tangential
    elements are linear springs K_T. Unused entries (chi for Jenkins, F_S of a stuck patch) hold values that make
    the laws well defined and are never read for those patches.
    """

    model: FrictionModel
    slip_force: np.ndarray
    stiffness: np.ndarray
    chi: np.ndarray
    beta: np.ndarray
    theta: np.ndarray
    normal_stiffness: np.ndarray
    core_stiffness: np.ndarray
    stuck: np.ndarray


def parameter_names(model: str, n_groups: int, stuck_group: int | None = None) -> list[str]:
    """Names of the design vector's entries, e.g. 'F_S[0]' (group index in brackets)."""
    return friction_model(model).parameter_names(n_groups, stuck_group)


def contained_unit_designs(unit, model: str, n_groups: int) -> np.ndarray:
    """Unit designs (n, d) of ``model`` that are the unit designs (n, d') of the model it contains
    (``FrictionModel.contains``): its shared parameters copied, those it adds at
    ``nonlinear.friction_models.CONTAINED_UNIT``. Raises FrictionParameterError for a model that contains none."""
    inner = friction_model(model).contains
    if inner is None:
        raise FrictionParameterError(f"the {model} model contains no other model")
    unit = np.atleast_2d(np.asarray(unit, dtype=float))
    position = {name: k for k, name in enumerate(parameter_names(inner, n_groups))}
    columns = [unit[:, position[name]] if name in position else np.full(len(unit), CONTAINED_UNIT[name.split("[")[0]])
               for name in parameter_names(model, n_groups)]
    return np.column_stack(columns)


def parameter_limits(model: str, n_groups: int, stuck_group: int | None = None):
    """Table 3 limits of the model's design vector: lower (d,), upper (d,), logarithmic (d,) bool."""
    names = [name.split("[")[0] for name in parameter_names(model, n_groups, stuck_group)]
    lower, upper, logarithmic = (np.array([TABLE3_LIMITS[name][i] for name in names]) for i in range(3))
    return lower.astype(float), upper.astype(float), logarithmic.astype(bool)


def from_unit(unit, lower, upper, logarithmic) -> np.ndarray:
    """Parameters (n, d) of unit designs (n, d) in [0, 1]: p = lo + u (hi - lo), in log p where Table 3
    samples logarithmically."""
    low, high = sampling_scale(lower, logarithmic), sampling_scale(upper, logarithmic)
    values = low + np.asarray(unit, dtype=float) * (high - low)
    return np.where(logarithmic, np.exp(values), values)


def to_unit(designs, lower, upper, logarithmic) -> np.ndarray:
    """Unit designs (n, d) of parameters (n, d): the inverse of :func:`from_unit`."""
    low, high = sampling_scale(lower, logarithmic), sampling_scale(upper, logarithmic)
    return (sampling_scale(designs, logarithmic) - low) / (high - low)


def sampling_scale(values, logarithmic) -> np.ndarray:
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
    friction = friction_model(model)
    groups = np.asarray(patch_groups, dtype=int)
    n_groups = int(groups.max()) + 1
    names = friction.parameter_names(n_groups, stuck_group)
    designs = np.atleast_2d(np.asarray(designs, dtype=float))
    if designs.shape[1] != len(names):
        raise FrictionParameterError(
            f"model {model!r} with {n_groups} patch groups takes {len(names)} parameters {names}; "
            f"got {designs.shape[1]}")
    per_group = {name: np.tile(value, (designs.shape[0], n_groups)) for name, value in ELEMENT_DEFAULTS.items()}
    for column, name in enumerate(names):
        parameter, group = name[:-1].split("[")
        per_group[parameter][:, int(group)] = designs[:, column]
    ordered = [per_group[name] for name in ELEMENT_PARAMETERS]
    friction.check(*ordered)
    stuck = groups == friction.stuck_group_index(n_groups, stuck_group)
    return PatchElements(friction, *(values[:, groups] for values in ordered), stuck)


def scaled_law(elements: PatchElements) -> ScaledLaw:
    """Constants of every element's slip law: Iwan by Segalman's mapping, Jenkins as r = 0, s = F_S,
    phi_max = F_S / K_T, stuck patches r = s = 0 (no slip)."""
    phi_max, r, s = elements.model.slip_constants(elements.slip_force, elements.stiffness, elements.chi,
                                                  elements.beta)
    stuck = elements.stuck
    return ScaledLaw(np.where(stuck, 1.0, phi_max), np.where(stuck, 0.0, r), np.where(stuck, 0.0, s),
                     elements.chi, elements.theta)


def slip_displacement(elements: PatchElements) -> np.ndarray:
    """Displacement at which an element reaches macroslip (m), (n_designs, n_patches): F_S / K_T for Jenkins,
    phi_max for Iwan, +inf for stuck patches."""
    return np.where(elements.stuck, np.inf, scaled_law(elements).phi_max)


def tangential_tangent(elements: PatchElements, displacement) -> np.ndarray:
    """Tangent stiffness df/du = K_c + K_T - g'(u) (N/m) of the tangential elements, from the scaled slip law
    (``nonlinear.slip_laws.backbone_force_slope``): K_c + K_T at zero displacement, K_c beyond macroslip; K_T for
    stuck patches."""
    law = scaled_law(elements)
    tangent = slip_laws.backbone_force_slope(displacement / law.phi_max, law.r, law.s, law.chi, law.theta) / law.phi_max
    return elements.core_stiffness + np.where(elements.stuck, elements.stiffness, tangent)


def tangential_force(elements: PatchElements, displacement) -> np.ndarray:
    """Force f = K_c u + K_T u - g(u) (N) of the tangential elements at displacement (m), their backbones (paper
    Eqs. 14, 18, 21) from the scaled slip law (``nonlinear.slip_laws.backbone_force``) plus the core's K_c u:
    K_c u + constant beyond macroslip (no K_T u - g cancellation there); K_T u for stuck patches."""
    law = scaled_law(elements)
    force = slip_laws.backbone_force(displacement / law.phi_max, law.r, law.s, law.chi, law.theta)
    return elements.core_stiffness * displacement + np.where(elements.stuck, elements.stiffness * displacement, force)


def tangential_slip_deficit(elements: PatchElements, displacement) -> np.ndarray:
    """Force lost to slip, (K_c + K_T) u - f(u) = K_T u - f_Iwan(u) (N), of the tangential elements (the core
    loses nothing); zero for stuck patches."""
    law = scaled_law(elements)
    return slip_laws.slip_deficit(displacement / law.phi_max, law.r, law.s, law.chi, law.theta)


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
    return PatchElements(elements.model, *(np.repeat(a, 2, axis=-1) for a in elements[1:]))


def tangential_rows(n_patches: int) -> np.ndarray:
    """Rows of the tangential (x, y) translations among the 3 n_patches relative joint translations."""
    return (np.arange(n_patches)[:, None] * 3 + np.arange(2)).ravel()


def stuck_stiffness(elements: PatchElements) -> np.ndarray:
    """Initial tangents of all joint springs (N/m), (n_designs, 3 n_patches) ordered x, y, z per patch: K_T + K_c
    tangentially, K_z normally."""
    tangential = elements.stiffness + elements.core_stiffness
    return np.stack([tangential, tangential, elements.normal_stiffness], axis=-1).reshape(
        elements.stiffness.shape[0], -1)


def joint_row_stiffness(stiffness, n_rows: int) -> np.ndarray:
    """Spring stiffness on every joint row (..., n_rows), N/m, from the stuck tangents (..., 3 n_patches) of
    ``stuck_stiffness`` (returned unchanged when they already have n_rows entries): the translations' as given;
    where the joint also acts on the patch rotations (n_rows = 5 n_patches,
    ``reduction.superelement.Superelement.joint_motion``: two rows per patch after the translations) each patch's
    normal stiffness K_z on its two rotational rows, the normal springs spread over the patch (rotational
    stiffness K_z J_p / A_p, N m/rad)."""
    stiffness = np.asarray(stiffness, dtype=float)
    if stiffness.shape[-1] == n_rows:  # already on every row
        return stiffness
    n_patches = stiffness.shape[-1] // 3
    if stiffness.shape[-1] != 3 * n_patches or n_rows != 5 * n_patches:
        raise ValueError(f"{n_rows} joint rows for {n_patches} patches: expected {3 * n_patches} (translations) "
                         f"or {5 * n_patches} (translations and the normal springs' rotational rows)")
    normal = stiffness[..., 2::3]
    return np.concatenate([stiffness, np.repeat(normal, 2, axis=-1)], axis=-1)
