"""The effects of the discrepancy loop, one registry: every other module reads ``EFFECTS`` or asks
``effect(name)``.

An effect is what a model of a measured mode may lack. Each names its parameters in the one-mode model
(``discrepancy.loop``: the kind of their fitted variable and their start), whether it belongs to the joint's friction
law (the law a joint is characterised by: the verdict names such effects as the joint law) or lies outside the
joint (what the structure's model lacks besides the joint), what it is, the nominal value it is an offset of where
it is one (``discrepancy.nominal``: the nominal and such an offset are one number), and an instance large enough to
matter at the study's tolerances, small enough to be real (``discrepancy.virtual_data``). The friction models say
which friction effects each brings to the superelement route (``FRICTION_EFFECTS``, from
``nonlinear.friction_models``). Adding an effect is one entry here, its term in the models
(``discrepancy.loop.model_backbone``, ``outside_joint``) and its tests.

    microslip          Iwan instead of Jenkins (chi, beta): damping from the first amplitude, no kink
    stiction           static slip force above the dynamic one (theta < 1): a drop in frequency at slip
    linear_damping     a structure-specific zeta_0 (free): an offset of the damping at every amplitude
    amplitude_damping  damping outside the joint growing with amplitude (air, suspension): + c q / q_max
    stiffness_change   a linear stiffness or mass change outside the joint (sensor mass, a mis-set constant,
                       prestress on a modal model): f_0 free, an offset of the frequency at every amplitude
    cubic_stiffening   geometric stiffening: omega^2 + gamma omega_0^2 (q / q_max)^2, frequency rising with q
    second_slip_stage  a second group of contact patches slipping at its own load: a second element of the
                       joint's law (kappa_2, F_S,2) in parallel with the joint's, a second drop of the frequency
                       and rise of the damping
    stuck_core         a linear spring beside each Iwan element that never slips (iwan4_core's K_c): the
                       superelement route alone, through its friction model; no parameter of the one-mode model

q_max is the largest fitted amplitude (the model's amplitude scale).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from nonlinear.friction_models import FRICTION_MODELS


@dataclass(frozen=True)
class Effect:
    """One effect of the registry.

    name: as the verdict and its files name it. parameters: its parameters in the one-mode model, each (name, kind,
    start): kind "log" (positive), "unit" (0, 1), "chi" (-1, 0), "shift" (-MAX_SHIFT, MAX_SHIFT) of
    ``discrepancy.loop.TRANSFORMS``, a start None for a slip force, started across the measured amplitudes
    (``discrepancy.loop.slip_starts``); empty where the one-mode model does not
    hold the effect. in_joint: it belongs to the joint's friction law. what: what it is, in words. offset_of: the
    nominal value ("frequency" f_0 or "damping" zeta_0) it offsets at every amplitude, None for an amplitude-dependent
    effect. instance: parameter values of a clear instance of it in the one-mode model. second_stage: its parameters
    are a second slip element's in parallel with the joint's, named as the joint element's with ``STAGE_SUFFIX``.
    """

    name: str
    parameters: tuple
    in_joint: bool
    what: str
    offset_of: str | None = None
    instance: dict = field(default_factory=dict)
    second_stage: bool = False


EFFECTS = {entry.name: entry for entry in (
    Effect("microslip", (("chi", "chi", -0.5), ("beta", "log", 0.1)), True, "Iwan's law instead of Jenkins'",
           instance={"chi": -0.4, "beta": 0.2}),
    Effect("stiction", (("theta", "unit", 0.7),), True, "a static slip force above the dynamic one",
           instance={"theta": 0.6}),
    Effect("linear_damping", (("zeta_0", "log", None),), False, "a linear damping not from the joint",
           offset_of="damping", instance={"zeta_0": 3.5e-3}),
    Effect("amplitude_damping", (("air_damping", "log", 1e-4),), False,
           "a damping outside the joint growing with amplitude", instance={"air_damping": 2e-3}),
    Effect("stiffness_change", (("frequency_shift", "shift", 0.0),), False,
           "a stiffness or mass change outside the joint", offset_of="frequency", instance={"frequency_shift": -0.01}),
    Effect("cubic_stiffening", (("cubic", "log", 1e-4),), False, "a geometric stiffening", instance={"cubic": 0.01}),
    Effect("second_slip_stage", (("kappa_2", "log", 0.05), ("slip_force_2", "log", None)), True,
           "a second group of contact patches of the same law slipping at its own load",
           instance={"kappa_2": 0.06, "slip_force_2": 1.4}, second_stage=True),
    Effect("stuck_core", (), True, "a linear spring beside each friction element that never slips"),
)}
"""Every effect by name, in the order the one-mode loop tries them."""
EFFECT_NAMES = tuple(EFFECTS)
ONE_MODE_EFFECTS = tuple(name for name, entry in EFFECTS.items() if entry.parameters)
"""The one-mode model's effect library: the effects it holds parameters of."""
SECOND_STAGE = next(name for name, entry in EFFECTS.items() if entry.second_stage)
"""The effect that is a second slip element in the one-mode model."""
STAGE_SUFFIX = "_2"
"""The second slip element's parameters are the joint element's stiffness share and slip force (kappa, slip_force)
with this suffix; it follows the joint element's law (chi, beta, theta)."""
OUTSIDE_JOINT = tuple(name for name, entry in EFFECTS.items() if not entry.in_joint)
"""The effects outside the joint, which both routes fit beside the joint's friction model."""
FRICTION_EFFECTS = {name: model.discrepancy_effects for name, model in FRICTION_MODELS.items()
                    if model.discrepancy_effects is not None}
"""Friction model -> the friction effects it adds to the macroslip reference (``nonlinear.friction_models``)."""


def effect(name: str) -> Effect:
    """The registry's effect of that name; ValueError listing the effects otherwise."""
    try:
        return EFFECTS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown effect {name!r}; choose one of {EFFECT_NAMES}") from None


def offset_effect(nominal: str) -> Effect:
    """The effect that offsets the nominal value ``nominal`` ("frequency" or "damping") at every amplitude."""
    return next(entry for entry in EFFECTS.values() if entry.offset_of == nominal)
