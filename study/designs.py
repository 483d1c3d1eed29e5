"""Designs of a study: a replicated Latin hypercube over paper Table 3, regenerated exactly from the seed.

The sample of one friction model is cut into chunks of ``chunk_size`` designs. Chunk c is a Latin hypercube of
its own (scipy.stats.qmc.LatinHypercube, every parameter's range split into chunk_size equally likely strata,
one design per stratum), drawn with the seed sequence (seed, model index, c): any chunk is regenerated
exactly, alone and in any order, without the rest of the sample in memory (a single hypercube over 5 x 10^6
designs would not stream), and the union of chunks is a replicated Latin hypercube (each chunk stratified, the
chunks independent). Replicate population r (the paper's Table 6 replicates) is the chunks c = r mod
n_replicates.

Unit designs u in [0, 1)^d map to parameters by Table 3 (``nonlinear.joint.from_unit``): p = lo + u (hi - lo)
for linear parameters and log p = log lo + u (log hi - log lo) for those Table 3 samples logarithmically.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import from_unit, parameter_limits


def chunk_seed(seed: int, model: str, chunk: int) -> np.random.SeedSequence:
    """The seed sequence of one chunk of one model's sample."""
    return np.random.SeedSequence([seed, MODEL_NAMES.index(model), chunk])


def unit_chunk(seed: int, model: str, chunk: int, chunk_size: int, dimension: int) -> np.ndarray:
    """Chunk ``chunk`` of the model's unit sample: a Latin hypercube (chunk_size, dimension) in [0, 1)."""
    generator = np.random.default_rng(chunk_seed(seed, model, chunk))
    return qmc.LatinHypercube(d=dimension, rng=generator).random(chunk_size)


def design_chunk(seed: int, model: str, chunk: int, chunk_size: int, n_groups: int,
                 stuck_group: int | None = None) -> np.ndarray:
    """Parameters (chunk_size, d) of chunk ``chunk`` of the model's sample over Table 3."""
    lower, upper, logarithmic = parameter_limits(model, n_groups, stuck_group)
    return from_unit(unit_chunk(seed, model, chunk, chunk_size, len(lower)), lower, upper, logarithmic)
