"""The effect registry: every effect a friction model brings is one of its effects in the joint's law, each nominal
value has one offset effect outside the joint, the second slip stage is one effect of the joint's law named as the
joint element's parameters, and an unknown name is refused with the list."""

import pytest

from discrepancy.effects import (EFFECT_NAMES, EFFECTS, FRICTION_EFFECTS, ONE_MODE_EFFECTS, SECOND_STAGE, STAGE_SUFFIX,
                                 effect, offset_effect)
from discrepancy.loop import BASE


def test_the_friction_models_bring_effects_of_the_joints_law():
    brought = {name for effects in FRICTION_EFFECTS.values() for name in effects}
    assert brought and all(effect(name).in_joint for name in brought)


def test_each_nominal_value_has_one_offset_effect_outside_the_joint():
    for nominal in ("frequency", "damping"):
        offsets = [entry for entry in EFFECTS.values() if entry.offset_of == nominal]
        assert offsets == [offset_effect(nominal)] and not offsets[0].in_joint


def test_the_second_slip_stage_is_one_effect_of_the_joint_law_named_as_the_joint_element():
    stages = [entry for entry in EFFECTS.values() if entry.second_stage]
    assert [entry.name for entry in stages] == [SECOND_STAGE] and stages[0].in_joint
    assert [(name, kind) for name, kind, _ in stages[0].parameters] == [
        (name + STAGE_SUFFIX, "log") for name, _, _ in BASE]


def test_every_one_mode_effect_has_an_instance_of_its_parameters():
    for name in ONE_MODE_EFFECTS:
        assert set(EFFECTS[name].instance) == {parameter for parameter, _, _ in EFFECTS[name].parameters}


def test_an_unknown_effect_is_refused_with_the_list():
    with pytest.raises(ValueError, match="unknown effect 'friction'; choose one of") as error:
        effect("friction")
    assert all(name in str(error.value) for name in EFFECT_NAMES)
