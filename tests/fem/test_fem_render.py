"""Renders of ``surrogacy fe`` on a very coarse BRB (scale factor 4 on the default sizes, about 10k DOF): contact
pressure (paper Fig. 7a) and first bending (Fig. 8) (about 15 s: one preload and two tied eigen-solves)."""

import json

import numpy as np
import pytest
from matplotlib import colormaps
from PIL import Image

from fem.fe_files import make_fe
from fem.convergence import scaled_sizes
from fem.render import PRESSURE_COLOURMAP, corner_means, nodal_pressure
from geometry.beams import make_beam
from geometry.parameters import BEAMS, MeshParameters


@pytest.fixture(scope="module")
def fe_folder(tmp_path_factory):
    beams, out = tmp_path_factory.mktemp("beams"), tmp_path_factory.mktemp("fe")
    make_beam(BEAMS["BRB"], scaled_sizes(MeshParameters(), 4.0), beams, render=False)
    make_fe("BRB", beams, out, n_modes=8)
    return out


def image(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(float)


def test_pressure_is_force_over_consistent_area_and_corners_show_the_mean_of_their_edges():
    # One six-node triangle: corners 0-2, mid-sides 3 (01), 4 (12), 5 (20); areas A/3 at the mid-sides only.
    pressure = nodal_pressure(np.array([0.0, 0.0, 0.0, 3.0, 6.0, 9.0]), np.array([0, 0, 0, 1.0, 1.0, 1.0]))
    np.testing.assert_array_equal(pressure[3:], [3.0, 6.0, 9.0])
    assert np.all(np.isnan(pressure[:3]))
    shown = corner_means(np.arange(6)[None], pressure)
    np.testing.assert_allclose(shown, [6.0, 4.5, 7.5, 3.0, 6.0, 9.0])


def test_fe_writes_readable_renders_recorded_in_the_sidecar(fe_folder):
    record = json.loads((fe_folder / "BRB.json").read_text())
    for kind in ("contact_pressure", "first_bending"):
        path = fe_folder / f"BRB_{kind}.png"
        assert record["files"][kind]["name"] == path.name
        pixels = image(path)
        assert pixels.shape[0] > 500 and pixels.shape[1] > 1000
        coloured = np.ptp(pixels, axis=2) > 60  # saturated pixels: the colour map, not the white/grey background
        assert coloured.mean() > 0.03, f"{path.name} is nearly blank"


def test_contact_pressure_colours_span_the_computed_pressure_range(fe_folder):
    """The recorded colour range is the computed pressure range: from 0 (the open lap ends) to the peak, which
    with the sum of the contact forces 3 x 11,580 N over a lap of 3.1e-3 m^2 must exceed the mean 11 MPa.
    Both ends of the colour map appear in the image (lighting is off, so colours are the map's own)."""
    record = json.loads((fe_folder / "BRB.json").read_text())
    low, high = record["contact_pressure_range_pa"]
    with np.load(fe_folder / "BRB.npz", allow_pickle=False) as arrays:
        forces = arrays["contact_force"]
        active = arrays["contact_active"]
    assert low == pytest.approx(0.0, abs=1e-6 * high)
    assert np.count_nonzero(~active) > 0
    assert high > 3 * 11580.0 / (0.12141 * 0.0254)
    assert forces.sum() == pytest.approx(3 * 11580.0, rel=1e-6)
    pixels = image(fe_folder / "BRB_contact_pressure.png")
    for end in (0.0, 1.0):
        colour = np.array(colormaps[PRESSURE_COLOURMAP](end)[:3]) * 255
        assert np.min(np.linalg.norm(pixels - colour, axis=2)) < 12, f"colour-map end {end} missing"
