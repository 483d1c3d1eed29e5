"""The library under ``surrogacy epmc`` (``virtual_experiment.nonlinear_mode``): its inputs checked in its own
terms before any solve, and each method's backbone holding only the levels that method reached."""

import numpy as np
import pytest

from reduction.superelement import beam_superelement
from virtual_experiment.nonlinear_mode import follow_mode, method_backbone, read_superelement

JENKINS_DESIGN = np.array([300, 1e7, 1e9] * 3)  # F_S (N), K_T, K_z (N/m) of the BRB's three patch groups


def test_a_superelement_of_another_format_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "BRB.txt"
    path.write_text("")
    with pytest.raises(ValueError, match=r"BRB\.txt: expected a \.npz \(surrogacy rom\) or an ASB \.mat"):
        read_superelement(path)


@pytest.mark.parametrize("options, message", [
    ({"mode": 0}, "mode = 0: expected a tied mode"),
    ({"start": 2.0, "stop": 1.0}, "expected 0 < from < to"),
    ({"levels": 1}, "at least 2 levels"),
    ({"harmonics": 200, "samples": 256}, "harmonics = 200: expected 1 to fewer than half of the samples"),
])
def test_options_out_of_range_are_refused_before_any_solve(beam_roms, options, message):
    with pytest.raises(ValueError, match=message):
        follow_mode(beam_superelement(beam_roms / "BRB.npz"), "jenkins", JENKINS_DESIGN, **options)


def test_each_backbone_holds_the_levels_its_method_reached(beam_roms):
    """Stuck levels and slipping ones at three harmonics: both methods reach every level of this design, at the
    same amplitudes, and EPMC's backbone records its harmonics and the slip amplitude."""
    followed = follow_mode(beam_superelement(beam_roms / "BRB.npz"), "jenkins", JENKINS_DESIGN, start=0.3, stop=8.0,
                           levels=4, harmonics=3)
    epmc, qsma = (method_backbone(followed, method, "BRB", "test") for method in ("epmc", "qsma"))
    assert followed.reached("epmc").all() and followed.reached("qsma").all()
    np.testing.assert_array_equal(epmc.backbone.amplitude, followed.amplitudes)
    np.testing.assert_array_equal(qsma.backbone.amplitude, followed.amplitudes)
    assert epmc.settings["harmonics"] == 3 and epmc.settings["slip_amplitude"] == followed.slip and not qsma.settings
    assert epmc.provenance == qsma.provenance == "virtual"
