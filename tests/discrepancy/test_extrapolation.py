"""The one-mode final model beyond its measured range, as discrepancy.md and its figure show it.

Checked: where the backbone's amplitude is a sensor's displacement in m (a ring-down through FreeVib), each row of
the extrapolation table gives its acceleration amplitude (2 pi f)^2 x, and the table states the top of the measured
range in m/s^2; where the amplitude is a modal one (m kg^0.5) no acceleration is claimed. On the Chen et al. 2022
hammer ring-down of the BRB (``../shared/data/chen2022-brb-hammer``, measured; skipped where absent), run as the demo
runs it, the measured range ends at the backbone's top point, the centre of the amplitude bin whose upper edge is
the hammer's top amplitude, 29.8 m/s^2 (half a bin below it, within 3 %: the number read from the measurement, not
set here), the rows above it are marked extrapolation with a 95 % band that widens with
the distance from the measured range, and the figure is written.
"""

import json

import numpy as np
import pytest

from cli.console import main
from discrepancy.files import acceleration, extrapolation_markdown
from discrepancy.fitted_model import evaluate, model_record
from discrepancy.loop import base_starts, fit
from discrepancy.virtual_data import REFERENCE_DAMPING, REFERENCE_FREQUENCY_HZ, undeclared_backbone
from experiment.measured_files import read_mode_backbone
from locations import SHARED
from study.structures import measured_levels

CHEN = SHARED / "data" / "chen2022-brb-hammer" / "HammerImpact.mat"
HAMMER_TOP = 29.8  # m/s^2, the hammer ring-down's largest acceleration amplitude


def virtual_record(unit):
    measurement = measured_levels(undeclared_backbone(("microslip",), seed=3))
    final = fit(measurement, ("microslip",), REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING,
                base_starts(measurement, REFERENCE_FREQUENCY_HZ))
    return {**model_record(final, measurement, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING), "amplitude_unit": unit}


def test_acceleration_column_only_for_a_displacement_in_metres():
    assert acceleration(1e-4, 80.0, "m") == pytest.approx((2 * np.pi * 80.0) ** 2 * 1e-4, rel=1e-12)
    assert acceleration(1e-4, 80.0, "m kg^0.5") is None and acceleration(1e-4, 80.0, None) is None
    record = virtual_record("m")
    text = extrapolation_markdown(record)
    high = record["fitted_range"][1]
    top = acceleration(high, evaluate(record, [high])["frequency_hz"][0], "m")
    assert f"({top:.3g} m/s^2 at the top)" in text and "| acceleration (m/s^2) |" in text
    rows = [line for line in text.splitlines() if line.startswith("| ") and "band" not in line]
    assert [row.split(" | ")[2] for row in rows] == ["fitted range"] + ["extrapolation"] * 3
    modal = extrapolation_markdown(virtual_record("m kg^0.5"))
    assert "m/s^2" not in modal and "m kg^0.5" in modal


@pytest.mark.slow
@pytest.mark.skipif(not CHEN.is_file(), reason=f"{CHEN} not found (the Chen et al. 2022 hammer ring-down)")
def test_chen_ringdown_model_beyond_the_hammers_top_amplitude(tmp_path):
    """About 45 s on an idle core (FreeVib 5 s, the loop 40 s)."""
    assert main(["freevib", str(CHEN), "--mode-hz", "80.5", "--per-channel", "--provenance", "measured", "--out",
                 str(tmp_path / "freevib")]) == 0
    backbone = next((tmp_path / "freevib").glob("*_backbone.csv"))
    out = tmp_path / "chen2022"
    assert main(["discrepancy", str(backbone), "--out", str(out)]) == 0
    record = json.loads((out / "discrepancy.json").read_text())["final_model"]
    assert record["amplitude_unit"] == "m"
    high = record["fitted_range"][1]
    curve = evaluate(record, high * np.array([1.0, 1.5, 2.0, 3.0]))
    points = read_mode_backbone(backbone).backbone.amplitude
    half_bin = np.sqrt(points[-1] / points[-2])  # the grid's points are the centres of equal bins in ln a
    assert acceleration(high, curve["frequency_hz"][0], "m") * half_bin == pytest.approx(HAMMER_TOP, rel=0.03)
    assert list(curve["extrapolated"]) == [False, True, True, True]
    width = np.diff(curve["frequency_band"], axis=0)[0]
    assert np.all(np.diff(width) > 0), width  # the band widens away from the measured range
    text = (out / "discrepancy.md").read_text()
    assert "m/s^2 at the top): the measured range" in text and text.count("| extrapolation |") == 3
    assert (out / "discrepancy.png").stat().st_size > 0
