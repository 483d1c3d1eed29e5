"""Acceptance bounds from the data: for each friction model and structure, the L-infinity errors (paper Eqs.
26-27) a design may have and still count as fitting that measurement about as well as the joint model can.

Rule. With e_f*, e_zeta* the errors of the calibrated best compromise (``calibration.calibrate``: the lowest
chi^2 of frequency and damping together, so one design reaches both at once) as the study evaluates a design (its
joint parameters with the study's zeta_0 for the damping case and its damping rule, ``study.errors.design_errors``:
the calibration fits its own zeta_0, and the study's damping errors are up to twice the calibrated ones where the
two differ) and sigma_f, sigma_zeta the measurement's standard uncertainties (``study.structures.BackboneLevels``),

    f_b    = max(MULTIPLE e_f*,    NOISE_MULTIPLE max_i sigma_f,i)       (Hz)
    zeta_b = max(MULTIPLE e_zeta*, NOISE_MULTIPLE max_i sigma_zeta,i)    (-)

each quantity on its own: a design is accepted where it misses the measurement by at most twice what the best
design of its model misses it by, and never by less than the measurement's own noise allows. The calibrated
optimum's scaled misfit (``study.errors.scaled_misfit``) is therefore at most 1 / MULTIPLE: every structure's
acceptance region holds at least one design, and its surrogacy row is defined. The bounds hold for the damping case
they were formed with (the ``damping_case`` column), which ``surrogacy confidence --bounds`` checks when it reads
them (``bounds.csv``, docs/formats.md). The paper's fixed 2 Hz and 5e-3 (``study.errors``) stay the study's bounds
for the comparison with its Table 5.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.files import atomic_path
from study.structures import BackboneLevels

MULTIPLE = 2.0
"""Bound as a multiple of the calibrated best compromise's L-infinity error."""
NOISE_MULTIPLE = 2.0
"""Smallest bound as a multiple of the measurement's largest standard uncertainty."""
BOUNDS_COLUMNS = ("model", "structure", "damping_case", "frequency_bound_hz", "damping_bound",
                  "best_frequency_error_hz", "best_damping_error", "calibrated_frequency_error_hz",
                  "calibrated_damping_error", "noise_frequency_hz", "noise_damping", "multiple", "noise_multiple")


def acceptance_bounds(study_errors: tuple[float, float], measurement: BackboneLevels) -> dict:
    """The bounds of one model on one structure from its best compromise's L-infinity errors as the study evaluates
    it, ``study_errors`` = (e_f Hz, e_zeta -), and the structure's measurement (module docstring)."""
    frequency_error, damping_error = study_errors
    noise_frequency = float(np.max(measurement.sigma_frequency))
    noise_damping = float(np.max(measurement.sigma_damping))
    return {"frequency_bound_hz": max(MULTIPLE * frequency_error, NOISE_MULTIPLE * noise_frequency),
            "damping_bound": max(MULTIPLE * damping_error, NOISE_MULTIPLE * noise_damping),
            "best_frequency_error_hz": frequency_error, "best_damping_error": damping_error,
            "noise_frequency_hz": noise_frequency, "noise_damping": noise_damping, "multiple": MULTIPLE,
            "noise_multiple": NOISE_MULTIPLE}


def bounds_table(records: list[dict], study_errors: list[tuple[float, float]], measurements: dict,
                 damping_case: str) -> pd.DataFrame:
    """One row per calibration record (``BOUNDS_COLUMNS``): study_errors, each record's best compromise's errors as
    the study evaluates it for ``damping_case`` (e_f Hz, e_zeta -); measurements: structure name -> BackboneLevels."""
    return pd.DataFrame([{"model": record["model"], "structure": record["structure"], "damping_case": damping_case,
                          **acceptance_bounds(errors, measurements[record["structure"]]),
                          "calibrated_frequency_error_hz": record["best"]["errors"]["frequency_linf_hz"],
                          "calibrated_damping_error": record["best"]["errors"]["damping_linf"]}
                         for record, errors in zip(records, study_errors)], columns=list(BOUNDS_COLUMNS))


def write_bounds(table: pd.DataFrame, destination: Path) -> None:
    """bounds.csv (full precision), atomically."""
    with atomic_path(destination) as temporary:
        table.to_csv(temporary, index=False, columns=list(BOUNDS_COLUMNS))
