"""Mesh-convergence machinery on three coarse BRB meshes (about 15 s); the full study is marked slow."""

import csv

import numpy as np
import pytest

from fem.convergence import FACTORS, TOLERANCE, changes_to_finer, converged_index, scaled_sizes
from geometry.parameters import MeshParameters
from pipeline.cli import parser


def run_study(folder, factors) -> list[dict]:
    arguments = parser().parse_args(["fe-convergence", "--beam", "BRB", "--out", str(folder),
                                     "--factors", *map(str, factors)])
    arguments.run(arguments)
    with open(folder / "BRB.csv", newline="") as stream:
        return [{key: float(value) for key, value in row.items()} for row in csv.DictReader(stream)]


def test_changes_and_the_converged_mesh_of_a_sequence():
    changes = changes_to_finer([204.0, 200.0, 199.2, 198.5, 198.3])
    np.testing.assert_allclose(changes[:-1], [204 / 200 - 1, 200 / 199.2 - 1, 199.2 / 198.5 - 1, 198.5 / 198.3 - 1])
    assert np.isnan(changes[-1])
    assert converged_index(changes) == 1  # 2 %, then 0.40 %, 0.35 %, 0.10 %: converged from the second mesh on
    # A small step between coarse meshes followed by a large one is not convergence.
    assert converged_index(np.array([0.02, 0.001, 0.008, 0.002, np.nan])) == 3
    assert converged_index(np.array([0.02, 0.01, np.nan])) is None


def test_scaled_sizes_scale_all_three_element_sizes():
    sizes = scaled_sizes(MeshParameters(), 2.0)
    base = MeshParameters()
    assert (sizes.size, sizes.lap_size, sizes.hole_size) == (2 * base.size, 2 * base.lap_size, 2 * base.hole_size)
    assert sizes.order == base.order


def test_tied_bending_frequency_decreases_with_refinement(tmp_path):
    """Quadratic tetrahedra are too stiff, so the tied first bending converges from above: measured 203.8, 200.1,
    198.3 Hz at 10k, 15k and 26k DOF (scale factors 4, 3, 2 on the default sizes), 1.8 % and 0.9 % steps. The
    sequence also stays within 5 % of the free-free Euler-Bernoulli bar less the holes (see test_fem_modes)."""
    rows = run_study(tmp_path, (4.0, 3.0, 2.0))
    frequencies = np.array([row["first_bending_hz"] for row in rows])
    assert np.all(np.diff([row["dof"] for row in rows]) > 0)
    assert np.all(np.diff(frequencies) < 0)
    np.testing.assert_allclose([row["change_to_finer"] for row in rows[:-1]], changes_to_finer(frequencies)[:-1])
    assert np.all(np.abs(frequencies / frequencies[-1] - 1) < 0.05)
    assert (tmp_path / "BRB.json").is_file()


@pytest.mark.slow
def test_default_mesh_is_the_coarsest_converged_one(tmp_path):
    """The full study (about 8 minutes here, 26k to 400k DOF): the default sizes of geometry.parameters are the
    coarsest of the sequence whose first bending changes by less than 0.5 % to the next finer mesh and on."""
    rows = run_study(tmp_path, FACTORS)
    changes = np.array([row["change_to_finer"] for row in rows[:-1]] + [np.nan])
    assert np.all(changes[:-1] > 0)
    assert rows[converged_index(changes, TOLERANCE)]["factor"] == 1.0
