"""Benchmark of the calibration stage (``calibration.calibrate``) on the measured ASB backbones: per configuration
and friction model, the wall time and the QSMA evaluations of one calibration seeded, as a study seeds it, with the
front of a Latin-hypercube-like sample (uniform in Table 3's unit box, zeta_0 at the lowest measured damping), and
the hypervolume of that sample's front against the calibrated one at their common reference point.

Run alone: ``python -m benchmarks.calibration [--designs 4000] [--configurations C1 CD1]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator

import numpy as np

from benchmarks import ASB_MODELS
from benchmarks.table import row, show
from calibration.calibrate import calibrate
from calibration.files import hypervolumes
from calibration.objectives import backbone_solver, fit_space, linf_errors, model_curves, unit_zeta0
from experiment.measured_files import read_mode_backbone
from nonlinear.joint import parameter_names
from study.datasets import ASB
from study.pareto import non_dominated
from study.structures import asb_superelement, structure


def rows(configurations=("C1", "CD1"), n_designs: int = 4000, seed: int = 0) -> Iterator[dict]:
    """One row per configuration and friction model of the ASB (module docstring)."""
    models_folder = ASB_MODELS
    backbones = models_folder.parent / "asb-backbones"
    for configuration in configurations:
        model_path = models_folder / f"MAT_NULLRED_{configuration}.mat"
        backbone_path = backbones / f"ASB_{configuration}_20Nm_BB.mat"
        if not (model_path.exists() and backbone_path.exists()):
            yield row("calibration", f"ASB {configuration}", note=f"skipped: no {model_path} or {backbone_path}")
            continue
        measured = structure(f"ASB {configuration}", asb_superelement(model_path), read_mode_backbone(backbone_path),
                             0.0)
        study_zeta0 = float(measured.measurement.damping[0])
        for model in ASB.models:
            space = fit_space(model, 1, measured.measurement)
            sample = np.random.default_rng(seed).random((n_designs, len(parameter_names(model, 1))))
            errors = linf_errors(measured.measurement, model_curves(
                measured, space, np.column_stack([sample, np.full(n_designs, unit_zeta0(space, study_zeta0))]),
                backbone_solver(measured)))
            front = non_dominated(errors)
            start = time.perf_counter()
            result = calibrate(measured, model, 1, sample[front], study_zeta0, seed)
            seconds = time.perf_counter() - start
            local = sum(fit.evaluations for fit in result.fits)
            sample_hv, calibrated_hv = hypervolumes(errors[front], result.front_errors)
            yield row("calibration", f"ASB {configuration}, {model}", seconds, rate=result.global_evaluations / seconds,
                      unit="global evaluations/s",
                      note=f"{result.global_generations} generations, {result.global_evaluations:,} global and "
                           f"{local:,} least-squares residual evaluations, each step with a Jacobian of 2 (d + 1) "
                           f"designs ({len(result.fits)} fits, "
                           f"{sum(fit.converged for fit in result.fits)} converged); hypervolume {calibrated_hv:.3f} "
                           f"against {sample_hv:.3f} of the front of {n_designs:,} sampled designs")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=4000, help="sampled designs whose front seeds each fit")
    parser.add_argument("--configurations", nargs="+", default=["C1", "CD1"])
    arguments = parser.parse_args(argv)
    show(rows(arguments.configurations, arguments.designs), [])


if __name__ == "__main__":
    main()
