"""Designs of a study: a replicated Latin hypercube over paper Table 3, regenerated exactly from the seed.

The sample is cut into chunks of ``chunk_size`` designs. Chunk c is one Latin hypercube of its own
(scipy.stats.qmc.LatinHypercube, every parameter's range split into chunk_size equally likely strata, one design
per stratum) over every parameter of the friction model registry, group by group (``sample_parameters``), drawn
with the seed sequence (seed, c): any chunk is regenerated exactly, alone and in any order, without the rest of
the sample in memory (a single hypercube over 5 x 10^6 designs would not stream), and the union of chunks is a
replicated Latin hypercube (each chunk stratified, the chunks independent). Replicate population r (the paper's
Table 6 replicates) is the chunks c = r mod n_replicates.

A friction model's design takes its own parameters' columns of that hypercube, by name (``nonlinear.joint
.parameter_names``); the columns of a Latin hypercube are themselves one, so each model's sample is a replicated
Latin hypercube over its own Table 3 box, as in the paper, and does not depend on which other models a study
holds. Design i of chunk c has the same value of a parameter in every model that has it (common random numbers):
the models compare design by design, and where two models' designs have the same stuck joint (K_T, K_z and, where
present, K_c) their stuck modes are formed once (``nonlinear.condensation.StuckModeCache``).

Unit designs u in [0, 1)^d map to parameters by Table 3 (``nonlinear.joint.from_unit``): p = lo + u (hi - lo)
for linear parameters and log p = log lo + u (log hi - log lo) for those Table 3 samples logarithmically.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from nonlinear.friction_models import ELEMENT_PARAMETERS
from nonlinear.joint import from_unit, parameter_limits, parameter_names


def sample_parameters(n_groups: int) -> list[str]:
    """Names of the sample's unit columns: every element parameter of the registry (``ELEMENT_PARAMETERS``) of
    each patch group, e.g. 'K_T[1]', group by group."""
    return [f"{name}[{group}]" for group in range(n_groups) for name in ELEMENT_PARAMETERS]


def unit_chunk(seed: int, chunk: int, chunk_size: int, n_groups: int) -> np.ndarray:
    """Chunk ``chunk`` of the unit sample: a Latin hypercube (chunk_size, len(sample_parameters)) in [0, 1)."""
    generator = np.random.default_rng(np.random.SeedSequence([seed, chunk]))
    return qmc.LatinHypercube(d=len(sample_parameters(n_groups)), rng=generator).random(chunk_size)


def chunk_designs(seed: int, models, chunk: int, chunk_size: int, n_groups: int,
                  stuck_group: int | None = None) -> dict[str, np.ndarray]:
    """Parameters (chunk_size, d_model) of chunk ``chunk`` of each model's sample over Table 3, by model name,
    from one unit hypercube (module docstring)."""
    unit = unit_chunk(seed, chunk, chunk_size, n_groups)
    column = {name: k for k, name in enumerate(sample_parameters(n_groups))}
    designs = {}
    for model in models:
        names = parameter_names(model, n_groups, stuck_group)
        designs[model] = from_unit(unit[:, [column[name] for name in names]],
                                   *parameter_limits(model, n_groups, stuck_group))
    return designs


def design_chunk(seed: int, model: str, chunk: int, chunk_size: int, n_groups: int,
                 stuck_group: int | None = None) -> np.ndarray:
    """Parameters (chunk_size, d) of chunk ``chunk`` of one model's sample over Table 3 (``chunk_designs``)."""
    return chunk_designs(seed, (model,), chunk, chunk_size, n_groups, stuck_group)[model]
