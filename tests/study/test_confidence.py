"""What a confidence estimate runs on (``study.confidence.estimate_inputs``): the damping case given, else the
study's dataset's default, and the acceptance bounds given one way, a bounds CSV or one pair on every structure."""

from types import SimpleNamespace

import numpy as np
import pytest

from study.confidence import acceptance_bounds, check_bounds_given, damping_case
from study.datasets import DATASETS


def study_of(dataset: str, names=("A", "B", "C")):
    """The parts of a study folder the choice reads: its dataset and its structures' names."""
    return SimpleNamespace(parameters={"study": SimpleNamespace(dataset=dataset)},
                           exploration=SimpleNamespace(names=list(names)))


@pytest.mark.parametrize("name", sorted(DATASETS))
def test_an_estimate_uses_the_damping_case_given_else_its_datasets_default(name):
    assert damping_case(study_of(name)) == DATASETS[name].default_damping_case
    assert damping_case(study_of(name), "LBRB") == "LBRB"


def test_one_pair_of_bounds_holds_on_every_structure():
    frequency, damping = acceptance_bounds(study_of("beams"), "jenkins", "BRB", None, 0.5, 2e-3)
    np.testing.assert_array_equal(frequency, [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(damping, [2e-3, 2e-3, 2e-3])


def test_bounds_from_a_csv_follow_the_studys_structures_in_their_order(tmp_path):
    path = tmp_path / "bounds.csv"
    path.write_text("model,structure,frequency_bound_hz,damping_bound,damping_case\n"
                    "jenkins,C,3.0,3e-3,BRB\njenkins,A,1.0,1e-3,BRB\njenkins,B,2.0,2e-3,BRB\niwan4,A,9.0,9e-3,BRB\n")
    frequency, damping = acceptance_bounds(study_of("beams"), "jenkins", "BRB", path)
    np.testing.assert_array_equal(frequency, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(damping, [1e-3, 2e-3, 3e-3])
    with pytest.raises(ValueError, match="bounds formed for \\['BRB'\\]; expected 'SBRB'"):
        acceptance_bounds(study_of("beams"), "jenkins", "SBRB", path)


@pytest.mark.parametrize("bounds, frequency, damping, expected", [
    ("bounds.csv", 0.5, None, "options --bounds and --frequency-bound: mutually exclusive"),
    ("bounds.csv", None, 2e-3, "options --bounds and --damping-bound: mutually exclusive"),
    (None, 0.5, None, "give either --bounds FILE or both"),
    (None, None, None, "give either --bounds FILE or both")])
def test_bounds_given_two_ways_or_half_given_are_refused(bounds, frequency, damping, expected):
    with pytest.raises(ValueError, match=expected):
        check_bounds_given(bounds, frequency, damping)
