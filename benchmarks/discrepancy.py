"""Benchmark of the one-mode discrepancy loop (``discrepancy.loop``): the fit's Jacobian as one batched model
evaluation against one evaluation per column, and whole loops with their fits and least-squares runs counted:

- the project's virtual backbone (``discrepancy.virtual_data.undeclared_backbone``) with a cubic stiffening, the
  nominal given;
- the ring-down challenge set's cubic stiffening (``ringdown-challenge/P5.csv.gz`` beside the project, virtual,
  another generator) through ``surrogacy freevib --mode-hz 170``, with the key's nominal and
  with the nominal estimated (the default test run's heaviest loop); skipped where the set is absent.

Run alone: ``python -m benchmarks.discrepancy``.
"""

from __future__ import annotations

import argparse
import gzip
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from unittest import mock

import numpy as np

import discrepancy.loop as loop
from benchmarks import MEASURED_DATA
from benchmarks.table import row, show
from cli.console import main as surrogacy
from discrepancy.nominal import nominal_record
from discrepancy.virtual_data import REFERENCE_DAMPING, REFERENCE_FREQUENCY_HZ, undeclared_backbone
from experiment.measured_files import read_mode_backbone
from study.structures import N_LEVELS, measured_levels

CHALLENGE = MEASURED_DATA / "ringdown-challenge"
CHALLENGE_NOMINAL = (169.86148, 1.666e-3)  # the challenge key's reference (its README)
JACOBIAN_EFFECTS = ("microslip", "second_slip_stage", "cubic_stiffening")
REPEATS = 200


def jacobian_row(measurement) -> dict:
    """The model at the p + 1 parameter sets of a forward-difference Jacobian, as one batched evaluation against
    p + 1 single ones (``JACOBIAN_EFFECTS``, at the measured levels), best of ``REPEATS``."""
    specification = loop.model_variables(JACOBIAN_EFFECTS)
    rows = np.random.default_rng(0).normal(size=(len(specification) + 1, len(specification)))
    scale = float(measurement.amplitude[-1])

    def batched():
        return loop.model_backbone(loop._to_parameters(rows.T[:, :, None], specification), measurement.amplitude,
                                   REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING, scale)

    def one_by_one():
        return [loop.model_backbone(loop._to_parameters(variables, specification), measurement.amplitude,
                                    REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING, scale) for variables in rows]

    assert np.allclose(np.asarray(batched()[0]), [frequency for frequency, _ in one_by_one()], equal_nan=True)
    times = {}
    for name, call in (("batched", batched), ("one by one", one_by_one)):
        best = np.inf
        for _ in range(REPEATS):
            start = time.perf_counter()
            call()
            best = min(best, time.perf_counter() - start)
        times[name] = best
    return row("discrepancy", f"Jacobian, {len(rows)} parameter sets", rate=times["one by one"] / times["batched"],
               unit="x one by one",
               note=f"{', '.join(JACOBIAN_EFFECTS)} at {measurement.amplitude.size} levels: one batched model "
                    f"evaluation {times['batched'] * 1e3:.3f} ms against {len(rows)} single ones "
                    f"{times['one by one'] * 1e3:.3f} ms, best of {REPEATS}")


def loop_row(case: str, measurement, nominal_frequency_hz: float, nominal_damping: float,
             nominal_uncertainty=(0.0, 0.0)) -> dict:
    """One loop's wall time, with its fits and least-squares runs counted and its answer."""
    with mock.patch.object(loop, "least_squares", wraps=loop.least_squares) as runs, \
            mock.patch.object(loop, "fit", wraps=loop.fit) as fits:
        start = time.perf_counter()
        verdict = loop.discrepancy_loop(measurement, nominal_frequency_hz, nominal_damping,
                                        nominal_uncertainty=nominal_uncertainty)
        seconds = time.perf_counter() - start
    final = verdict.final
    dof = 2 * measurement.amplitude.size - final.n_parameters
    return row("discrepancy", case, seconds, rate=fits.call_count / seconds, unit="fits/s",
               note=f"{fits.call_count} fits, {runs.call_count:,} least-squares runs; answer: "
                    f"{', '.join(verdict.effects) or 'the reference'}, chi^2/dof {final.chi_squared / dof:.2f}")


def rows() -> Iterator[dict]:
    """The rows of the module docstring."""
    virtual = measured_levels(undeclared_backbone(("cubic_stiffening",), seed=0), N_LEVELS, "virtual backbone")
    yield jacobian_row(virtual)
    yield loop_row("loop, virtual cubic (project)", virtual, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING)
    packed = CHALLENGE / "P5.csv.gz"
    if not packed.is_file():
        yield row("discrepancy", "loop, challenge P5", note=f"skipped: no {packed}")
        return
    with tempfile.TemporaryDirectory() as folder:
        ringdown = Path(folder) / "P5.csv"
        ringdown.write_bytes(gzip.decompress(packed.read_bytes()))
        assert surrogacy(["freevib", str(ringdown), "--mode-hz", "170", "--out", str(Path(folder) / "fv")]) == 0
        backbone = next((Path(folder) / "fv").glob("*_backbone.csv"))
        measurement = measured_levels(read_mode_backbone(backbone), N_LEVELS, str(backbone))
    yield loop_row("loop, challenge P5, key's nominal", measurement, *CHALLENGE_NOMINAL)
    nominal = nominal_record(measurement, None, None)
    yield loop_row("loop, challenge P5, nominal estimated", measurement, nominal["nominal_frequency_hz"],
                   nominal["nominal_damping"], (nominal["nominal_frequency_standard_error_hz"],
                                                nominal["nominal_damping_standard_error"]))


def main(argv=None) -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    show(rows(), [])


if __name__ == "__main__":
    main()
