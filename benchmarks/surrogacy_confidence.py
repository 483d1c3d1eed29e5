"""Benchmark of the surrogacy confidence at tight bounds (``study.subset_simulation``) against brute force on the
measured ASB backbones C1-C3 (iwan4, zeta_0 at each configuration's lowest measured damping): per acceptance bounds,
the wall time and single-structure QSMA evaluations of subset simulation for C1 as the surrogate, the SC_C1,C3 it
gives with its interval, and a Latin hypercube of ``n_designs`` designs evaluated on the three structures: its
count of designs C1 accepts, its SC with its Clopper-Pearson interval, and the evaluations brute force needs for
subset simulation's interval width (3 n_eff / P(C1)).

Run alone: ``python -m benchmarks.surrogacy_confidence [--designs 20000]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator

import numpy as np

from benchmarks import ASB_MODELS
from benchmarks.table import row, show
from experiment.measured_files import read_mode_backbone
from study.designs import design_chunk
from study.errors import accepted
from study.exploration import Exploration, Sample, structure_errors
from study.structures import asb_superelement, structure
from study.subset_simulation import Settings, study_subset_simulation
from study.surrogacy import surrogacy_matrix

CONFIGURATIONS = ("C1", "C2", "C3")
BOUNDS = ((2.0, 5e-3), (0.3, 5e-4), (0.1, 3e-4))  # (Hz, -): the paper's, then tighter
MODEL = "iwan4"


def rows(n_designs: int = 20000, seed: int = 0) -> Iterator[dict]:
    """One row per acceptance bounds (module docstring)."""
    models_folder = ASB_MODELS
    structures = []
    for configuration in CONFIGURATIONS:
        model_path = models_folder / f"MAT_NULLRED_{configuration}.mat"
        backbone_path = models_folder.parent / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat"
        if not (model_path.exists() and backbone_path.exists()):
            yield row("surrogacy", "ASB C1-C3", note=f"skipped: no {model_path} or {backbone_path}")
            return
        structures.append(structure(configuration, asb_superelement(model_path), read_mode_backbone(backbone_path),
                                    0.0))
    cases = {"lowest": tuple(float(s.measurement.damping[0]) for s in structures)}
    exploration = Exploration(tuple(structures), (MODEL,), Sample(seed, n_designs, n_designs, 1), cases)
    designs = design_chunk(seed, MODEL, 0, n_designs, exploration.n_groups)
    errors = structure_errors(exploration, MODEL, designs)
    frequency = np.column_stack([error.frequency_error_hz for error in errors])
    damping = np.column_stack([error.damping_error[:, 0] for error in errors])
    for frequency_bound, damping_bound in BOUNDS:
        brute = surrogacy_matrix(accepted(frequency, damping, frequency_bound, damping_bound))
        start = time.perf_counter()
        result = study_subset_simulation(exploration, MODEL, "C1", "lowest", frequency_bound, damping_bound,
                                         Settings(seed=seed, n_per_level=3000))
        seconds = time.perf_counter() - start
        same_width = 3 * result.effective_size[2] / result.probability
        yield row("surrogacy", f"ASB C1 for C3, {frequency_bound:g} Hz / {damping_bound:g}", seconds,
                  rate=same_width / result.evaluations, unit="x fewer evaluations",
                  note=f"subset simulation: P(C1) {result.probability:.3g} (c.o.v. {result.probability_cov:.2f}), "
                       f"SC {result.confidence[2]:.3f} [{result.lower[2]:.3f}, {result.upper[2]:.3f}] from "
                       f"{result.families} families in {result.evaluations:,} evaluations; brute force "
                       f"{brute.accepted_counts[0]} of {n_designs:,} designs ({3 * n_designs:,} evaluations), SC "
                       f"{brute.confidence[0, 2]:.3f} [{brute.lower[0, 2]:.3f}, {brute.upper[0, 2]:.3f}], "
                       f"{same_width:,.0f} evaluations for subset simulation's width")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=20000, help="brute-force Latin hypercube designs")
    arguments = parser.parse_args(argv)
    show(rows(arguments.designs), [])


if __name__ == "__main__":
    main()
