"""The friction models of paper Table 2, one registry: every other module asks ``friction_model(name)``.

A friction model says what a joint design is: the parameters of each patch group and their Table 3 limits, the
law of its friction elements (the scaled slip law's constants, the slider set for time stepping, the physical
ranges checked), whether one patch group is stuck (a linear spring that never slips), whether its energy can have
several equilibria, and how the paper and the discrepancy loop name it. Adding a model is one entry of
``FRICTION_MODELS`` plus its tests.

    jenkins        (F_S, K_T, K_z)                     Jenkins element (paper 4.3.1), macroslip only
    iwan4          (F_S, K_T, chi, beta, K_z)          Segalman's four-parameter Iwan element (paper 4.3.2)
    iwan5          (F_S, K_T, chi, beta, theta, K_z)   the five-parameter Iwan element with stiction theta
                                                       (paper Eq. 20): the backbone falls after slip, the static
                                                       problem's energy is not convex and can hold several
                                                       equilibria
    iwan4_stuck    iwan4 groups, but the stuck group (the BRB's middle patch 3, the last group by default) is a
                   linear spring (K_T, K_z)
    iwan4_core     (F_S, K_T, chi, beta, K_c, K_z)     every patch's iwan4 element in parallel with a linear spring
                                                       K_c that never slips (the stuck core of the contact under
                                                       the bolt, as in the whole-joint Iwan models fitted to the
                                                       ASB): tangent K_T + K_c stuck, K_c beyond macroslip

The core spring K_c (N/m) is not in the paper's Table 3; its limits are K_T's (1e2 to 1e14 N/m, logarithmic), so
that the core ranges from negligible beside the structure to as stiff as the stiffest Iwan element. With the core
the tangential force is f = K_c u + K_T u - g(u), g the Iwan element's slip deficit (``nonlinear.slip_laws``) with
its own constants: the core enters only the stuck tangent K_T + K_c (the condensation's joint stiffness), never the
slip law, and no joint mechanism is left free in macroslip (the core holds it).

Convention: parameters are per patch pair, in N and N/m, not scaled by patch area.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nonlinear.iwan import segalman_constants
from nonlinear.parameters import (FrictionParameterError, check_iwan, check_jenkins, check_non_negative,
                                  check_positive)
from nonlinear.sliders import Sliders, iwan_sliders, jenkins_sliders, with_linear_spring
from pipeline.published import TABLE3

TABLE3_LIMITS = {**TABLE3, "K_c": TABLE3["K_T"]}
"""Paper Table 3 (``pipeline.published.TABLE3``): (minimum, maximum, logarithmic sampling) of each parameter (N, N/m
or dimensionless); the core stiffness K_c, not in the paper, takes K_T's limits (module docstring)."""
STUCK_GROUP_PARAMETERS = ("K_T", "K_z")
"""Parameters of a stuck patch group: its tangential and normal stiffness (N/m)."""
STIFFNESS_PARAMETERS = ("K_T", "K_z", "K_c")
"""The element parameters that are stiffnesses (N/m): one factor on all of them scales the stuck joint."""
ELEMENT_DEFAULTS = {"F_S": 1.0, "K_T": 1.0, "chi": -0.5, "beta": 0.0, "theta": 1.0, "K_z": 1.0, "K_c": 0.0}
"""Values of the element parameters a model does not have (chi of Jenkins, F_S of a stuck patch): they make every
slip law well defined and are never read for those elements; K_c = 0 is no core."""
SMALLEST_SLIDER = 1e-4
"""Default smallest slip displacement of an Iwan element's sliders, in units of phi_max (``FrictionModel.sliders``)."""
ELEMENT_PARAMETERS = ("F_S", "K_T", "chi", "beta", "theta", "K_z", "K_c")
"""Every element parameter, in the order of ``nonlinear.joint.PatchElements``' fields."""
CONTAINED_UNIT = {"theta": 1.0, "K_c": 0.0, "chi": 0.0, "beta": 1.0}
"""Unit coordinate in Table 3's box of each parameter a model adds to the model it contains (``FrictionModel
.contains``), at which it is that model: theta = 1, no stiction drop; K_c at its lower limit, 1e2 N/m, a core
negligible beside the joint; chi = -0.99 and beta = 1e4, Jenkins as near as Table 3's box allows: the backbone
departs from Jenkins' by at most 1e-4 F_S (full slip 1e-4 later) and a cycle below slip dissipates under 2e-6
F_S^2 / K_T (the calibration of the larger model starts from the smaller one's optimum there)."""


@dataclass(frozen=True)
class FrictionModel:
    """One friction model of the registry.

    name: as the study and its files name it. group_parameters: the design entries of one patch group, in order.
    element: the closed-form element of paper Table 2 its friction elements follow ("jenkins", "iwan4" or
    "iwan5"). stuck_group: one patch group is a linear spring (``STUCK_GROUP_PARAMETERS``). paper_name: its name
    in the paper's tables. discrepancy_effects: what it adds to the macroslip reference in the discrepancy loop's
    effect library (``discrepancy.superelement_route``), or None where the loop does not use it. in_paper: one of
    paper Table 2's models (the beams' study runs those by default, so that its ANOVA and Table 5 compare).
    contains: the model it reduces to with its added parameters at ``CONTAINED_UNIT`` (None: none).
    """

    name: str
    group_parameters: tuple[str, ...]
    element: str
    stuck_group: bool = False
    paper_name: str | None = None
    discrepancy_effects: tuple[str, ...] | None = None
    in_paper: bool = True
    contains: str | None = None

    @property
    def min_groups(self) -> int:
        """Fewest patch groups the model can describe (a stuck group needs another one that slips)."""
        return 2 if self.stuck_group else 1

    @property
    def several_equilibria(self) -> bool:
        """Whether the static problem's energy can have several minima (stiction: the backbone falls after slip);
        QSMA then follows the loading path from the stuck state."""
        return "theta" in self.group_parameters

    def stuck_group_index(self, n_groups: int, stuck_group: int | None = None) -> int | None:
        """The stuck group's index (default the last group), None for a model without one."""
        if not self.stuck_group:
            return None
        if n_groups < self.min_groups:
            raise FrictionParameterError(f"the {self.name} model needs at least {self.min_groups} patch groups; "
                                         f"got {n_groups}")
        return n_groups - 1 if stuck_group is None else stuck_group

    def parameter_names(self, n_groups: int, stuck_group: int | None = None) -> list[str]:
        """Names of the design vector's entries, e.g. 'F_S[0]' (group index in brackets)."""
        stuck = self.stuck_group_index(n_groups, stuck_group)
        return [f"{name}[{group}]" for group in range(n_groups)
                for name in (STUCK_GROUP_PARAMETERS if group == stuck else self.group_parameters)]

    @property
    def core(self) -> bool:
        """Whether every patch's tangential element has a linear spring K_c in parallel that never slips."""
        return "K_c" in self.group_parameters

    def check(self, slip_force, stiffness, chi, beta, theta, normal_stiffness, core_stiffness) -> None:
        """Raise FrictionParameterError naming a parameter outside its physical range."""
        check_positive(normal_stiffness, "normal stiffness K_z")
        check_non_negative(core_stiffness, "core stiffness K_c")
        if self.element == "jenkins":
            check_jenkins(stiffness, slip_force)
        else:
            check_iwan(slip_force, stiffness, chi, beta, theta)

    def slip_constants(self, slip_force, stiffness, chi, beta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Constants (phi_max m, r N, s N) of the scaled slip law (``nonlinear.slip_laws``) of its elements:
        Segalman's mapping for Iwan, r = 0, s = F_S, phi_max = F_S / K_T for Jenkins."""
        if self.element == "jenkins":
            return slip_force / stiffness, np.zeros_like(slip_force), slip_force
        return segalman_constants(slip_force, stiffness, chi, beta)

    def sliders(self, slip_force: float, stiffness: float, chi: float, beta: float, theta: float,
                core_stiffness: float = 0.0, smallest: float = SMALLEST_SLIDER) -> Sliders:
        """One element (scalar parameters) as a set of parallel sliders for time stepping (``nonlinear.sliders``),
        with the core (``core``) as one more slider of infinite strength. smallest: the smallest slip displacement
        an Iwan element's sliders resolve, in units of its macroslip displacement phi_max (its dissipation is
        accurate to about 1e-5 from 100 times that amplitude up; ``nonlinear.sliders.iwan_sliders``)."""
        element = (jenkins_sliders(stiffness, slip_force) if self.element == "jenkins"
                   else iwan_sliders(slip_force, stiffness, chi, beta, theta, smallest=smallest))
        return with_linear_spring(element, core_stiffness) if self.core else element


FRICTION_MODELS = {model.name: model for model in (
    FrictionModel("jenkins", ("F_S", "K_T", "K_z"), "jenkins", discrepancy_effects=()),
    FrictionModel("iwan4", ("F_S", "K_T", "chi", "beta", "K_z"), "iwan4", discrepancy_effects=("microslip",),
                  contains="jenkins"),
    FrictionModel("iwan5", ("F_S", "K_T", "chi", "beta", "theta", "K_z"), "iwan5",
                  discrepancy_effects=("microslip", "stiction"), contains="iwan4"),
    FrictionModel("iwan4_stuck", ("F_S", "K_T", "chi", "beta", "K_z"), "iwan4", stuck_group=True,
                  paper_name="iwan4_middle_stuck"),
    FrictionModel("iwan4_core", ("F_S", "K_T", "chi", "beta", "K_c", "K_z"), "iwan4",
                  discrepancy_effects=("microslip", "stuck_core"), in_paper=False, contains="iwan4"),
)}
"""Every friction model by name, in the order the study seeds them (``study.designs``)."""
MODEL_NAMES = tuple(FRICTION_MODELS)


def friction_model(name: str) -> FrictionModel:
    """The registry's model of that name; FrictionParameterError listing the models otherwise."""
    try:
        return FRICTION_MODELS[name]
    except (KeyError, TypeError):
        raise FrictionParameterError(f"unknown friction model {name!r}; choose one of {MODEL_NAMES}") from None


def models_for(n_groups: int, in_paper: bool = False) -> tuple[str, ...]:
    """The models a structure with ``n_groups`` patch groups can carry (a stuck group needs two groups); only the
    paper's where ``in_paper``."""
    return tuple(name for name, model in FRICTION_MODELS.items()
                 if n_groups >= model.min_groups and (model.in_paper or not in_paper))
