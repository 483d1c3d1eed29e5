"""From the exploration's Parquet rows to the study's answers: acceptance, surrogacy matrices with intervals,
their sensitivity to the bounds, the ANOVA's observations and the Pareto fronts (paper sections 4.4, 5.2).

Everything here reads only the columns it needs (``study.exploration.read_exploration``) and works on arrays;
the statistics themselves live in ``study.surrogacy``, ``study.anova`` and ``study.pareto``.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from study.errors import accepted
from study.exploration import read_exploration
from study.pareto import non_dominated
from study.surrogacy import replicate_surrogacy, replicate_table


class ModelErrors(NamedTuple):
    """One model's sample on every structure: frequency_error_hz (n, S) Hz, damping_error (n, S) for one
    linear damping case, replicate (n,) labels, design (n,) indices; NaN where not converged."""

    frequency_error_hz: np.ndarray
    damping_error: np.ndarray
    replicate: np.ndarray
    design: np.ndarray


def model_errors(folder: Path, model: str, names: list[str], case: str) -> ModelErrors:
    """The errors of one model's sample with linear damping case ``case``."""
    frequency = [f"frequency_error_hz[{name}]" for name in names]
    damping = [f"damping_error[{name}][{case}]" for name in names]
    frame = read_exploration(folder, model, ["design", "replicate", *frequency, *damping])
    return ModelErrors(frame[frequency].to_numpy(float), frame[damping].to_numpy(float),
                       frame["replicate"].to_numpy(int), frame["design"].to_numpy(np.int64))


def anova_observations(folder: Path, models, names: list[str], cases, frequency_tolerance_hz: float,
                       damping_tolerance: float) -> pd.DataFrame:
    """One surrogacy confidence per (surrogate, real, model, linear damping case, replicate population): the
    observations of the paper's Table 6 ANOVA (NaN where the replicate's surrogate accepted no design)."""
    tables = []
    for model in models:
        for case in cases:
            errors = model_errors(folder, model, names, case)
            acceptance = accepted(errors.frequency_error_hz, errors.damping_error, frequency_tolerance_hz,
                                  damping_tolerance)
            tables.append(replicate_table(replicate_surrogacy(acceptance, errors.replicate), names, model, case))
    return pd.concat(tables, ignore_index=True)


class Front(NamedTuple):
    """Non-dominated designs of one model's sample on one structure: design (k,) indices, frequency_error_hz
    (k,), damping_error (k,), sorted by frequency error."""

    design: np.ndarray
    frequency_error_hz: np.ndarray
    damping_error: np.ndarray


def sample_front(errors: ModelErrors, structure: int) -> Front:
    """The sample's Pareto front in the error plane of one structure (paper Fig. 6)."""
    points = np.column_stack([errors.frequency_error_hz[:, structure], errors.damping_error[:, structure]])
    mask = non_dominated(points)
    order = np.argsort(points[mask, 0])
    return Front(errors.design[mask][order], points[mask, 0][order], points[mask, 1][order])


def representative_designs(front: Front, frequency_tolerance_hz: float, damping_tolerance: float,
                           count: int = 3) -> np.ndarray:
    """``count`` designs spread along a front (paper Figs. 9-11): its two ends and the design nearest the origin
    with each error measured in its acceptance bound (the knee), then evenly between; indices into the front."""
    if len(front.design) <= count:
        return np.arange(len(front.design))
    scaled = np.hypot(front.frequency_error_hz / frequency_tolerance_hz, front.damping_error / damping_tolerance)
    chosen = [0, len(front.design) - 1, int(np.argmin(scaled))]
    for position in np.linspace(0, len(front.design) - 1, count + 2)[1:-1].round().astype(int):
        if len(set(chosen)) >= count:
            break
        chosen.append(int(position))
    return np.array(sorted(set(chosen))[:count])
