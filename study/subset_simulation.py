"""Surrogacy confidence at tight acceptance bounds by subset simulation (paper section 4.4, Eq. 29).

Random designs rarely fall into a structure's acceptance region when the bounds are tight: at P(accepted by I) =
1e-5, a sample of 1e6 designs gives SC_IJ from about ten accepted designs. Subset simulation (Au & Beck 2001) samples
the acceptance region of the surrogate I directly, over the same prior as the study's Latin hypercube (every
design parameter uniform over its Table 3 range, in log where Table 3 samples logarithmically), so that

    SC_IJ = P(accepted by J | accepted by I)

keeps the paper's meaning, while P(accepted by I) itself is estimated on the way.

Misfit. A design x is accepted by structure S when its scaled misfit g_S(x) = max(e_f / f_b, e_zeta / zeta_b) <= 1
(both L-infinity errors within their bounds, ``study.errors.accepted``; a design that did not converge has g = inf).
The nested regions {g_I <= b_k} with b_0 > b_1 > ... > b_m = 1 shrink both bounds in proportion, from loose to the
target.

Sampling space. A unit design u in [0, 1)^d (``nonlinear.joint.from_unit`` maps it to the parameters) is u = Phi(z)
with z standard normal, so the prior is the standard normal in z and the Markov chains below need no prior ratio.

Levels. Level 0 draws N designs from the prior. At level k the N designs are sorted by g_I; the threshold b_{k+1} is
the (p_0 N)-th smallest misfit, and the p_0 N designs below it seed p_0 N Markov chains of 1 / p_0 states each
(seed included), restricted to {g_I <= b_{k+1}}: the next level's N designs. The moves are adaptive conditional
sampling (Papaioannou, Betz, Zwirglmaier & Straub 2015): the proposal z' = rho z + sigma xi, xi standard normal,
sigma_i = min(lambda s_i, 1), rho_i = sqrt(1 - sigma_i^2), s_i the seeds' standard deviation in coordinate i, leaves
the prior invariant, and z' is taken when g_I(z') <= b_{k+1}. lambda is fixed within a level (so that each chain is
a Markov chain that keeps the conditional distribution) and moves between levels towards a fraction of 0.44 of the
proposals taken (log lambda += a - 0.44); a coordinate in which the seeds do not differ (chains gathered on one
design) takes the prior's spread s_i = 1. When the (p_0 N)-th smallest misfit is <= 1 the target is reached, and

    P(accepted by I) = prod_k p_k P_m,    P_m = fraction of the last level's designs with g_I <= 1,

p_k = p_0 except at ties. Where the misfit is flat over part of the region (a stuck joint's damping error does not
depend on its slip parameters) or the chains have gathered on one design, the (p_0 N)-th smallest misfit equals the
current threshold. The next threshold is then the largest misfit below it, p_k the fraction of designs at or below
that, and the p_0 N seeds are drawn from those fewer designs with replacement (each chain still starts in the
conditional distribution); where no design lies below, the threshold stays and the level is another round of moves
in the same region (p_k = 1).

Stalls and restarts. A run stalls where the threshold falls by less than ``STALL_SHARE`` of itself over
``STALL_LEVELS`` levels, or after ``MAX_LEVELS`` levels: its chains have gathered in a basin whose lowest misfit lies
above 1 and lost the designs that led to the region (a small second basin, or a narrow passage). Whether a run keeps
a design in the region's basin depends on how many designs each level holds, not on the level's share p_0, so where
any run stalls, all R runs are made again with fresh random numbers and twice the designs per level, at most
``restarts`` times (N, 2N, 4N, ...). The reported estimate is plain subset simulation at the N its runs used, with
the same prior and meaning; the stalled estimates' designs are discarded (their evaluations are counted). Keeping
only runs that reach the region selects on the outcome: a run that reaches a basin it seldom keeps over-represents
it, by about the inverse of the chance that a run reaches the region at that N. Asking all R runs to reach at one N
stops the doubling only where that chance is high (``tests/study/test_subset_simulation.py`` measures what is
left on a region behind a near-miss basin). Still stalled at N 2^restarts, the estimate raises ``RegionNotReached``
with the threshold the run stalled at and the lowest misfit reached.

Au & Beck's (2001, Eq. 29) coefficient of variation of one run, delta^2 = sum_k (1 - p_k) / (p_k N) (1 + gamma_k),
with gamma_k from the autocorrelation of the level's indicator along its chains (``chain_correlation_factor``),
ignores the correlation between levels, and on a narrow region reached through few chains the runs scatter far
more than it says. The estimator therefore makes R independent runs (default 4) and takes P as their mean and its
interval from their spread (``combined_probability``).

Surrogacy. In each run the last level's designs with g_I <= 1 seed chains restricted to {g_I <= 1} until
``n_conditional`` states are drawn: a sample of the prior given acceptance by I. Every structure J is evaluated on
them, and SC_IJ is the fraction of the R runs' conditional designs that J accepts. Its interval accounts for the
chains' correlation through their families (``family_confidence``): every design descends from one level-0 design
of its run, and designs of different families are independent.

The evaluations are batched: one call of the misfit per step of all chains, in this process or spread over a
dask.distributed cluster (``study_misfit``). The state after each level of each run (and restart) is a JSON file in
``state_folder`` (designs, misfits, families, thresholds, the generator's state), so that a killed estimate
restarts from its last finished level, stalls and restarts again where it did, and gives the same numbers as an
uninterrupted one.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable, NamedTuple, Sequence

import numpy as np
import pandas as pd
from scipy.special import ndtr
from scipy.stats import norm
from scipy.stats import t as student_t
from statsmodels.stats.proportion import proportion_confint

from nonlinear.joint import from_unit, parameter_limits
from pipeline.files import atomic_path, sha256_json, write_json
from pipeline.runners import SERIAL
from study.errors import scaled_misfit
from study.exploration import Exploration, process_splits, structure_errors
from study.surrogacy import CONFIDENCE_LEVEL, INTERVAL_METHOD

TARGET_ACCEPTANCE = 0.44  # fraction of conditional moves taken that lambda is adapted to
INITIAL_SCALE = 0.6  # lambda of the first level's chains
MIN_MINORITY_FAMILIES = 5  # families holding the rarer outcome needed to estimate the variance of SC
MAX_LEVELS = 40
STALL_LEVELS = 5  # levels over which the threshold must fall by STALL_SHARE of itself, else the run has stalled
STALL_SHARE = 0.01

Misfit = Callable[[np.ndarray, Sequence[int]], np.ndarray]
"""misfit(unit (n, d) in [0, 1], structures (k,) indices) -> (n, k) scaled misfit g_S; accepted where g_S <= 1."""


class Settings(NamedTuple):
    """How the estimator samples: seed (run r draws from numpy's Generator seeded with [seed, r], in restart a with
    [seed, r, a]); n_per_level N designs per level; level_probability p_0, the conditional probability between
    levels (p_0 N seeds of 1 / p_0 states each); n_conditional designs drawn in the surrogate's acceptance region
    for SC, per run; n_runs independent runs; restarts: how often the runs are made again with twice the designs
    per level where one stalls (module docstring), so that they use at most N 2^restarts."""

    seed: int = 2024
    n_per_level: int = 2000
    level_probability: float = 0.1
    n_conditional: int = 2000
    n_runs: int = 4
    restarts: int = 3

    def check(self) -> None:
        chains = self.n_per_level * self.level_probability
        if not (0.0 < self.level_probability < 1.0) or abs(chains - round(chains)) > 1e-9 or chains < 2 \
                or abs(1.0 / self.level_probability - round(1.0 / self.level_probability)) > 1e-9:
            raise ValueError(f"level_probability {self.level_probability} with n_per_level {self.n_per_level}: "
                             "expected 1 / level_probability and n_per_level * level_probability whole numbers, "
                             "the latter at least 2")
        for name, least in (("n_conditional", 1), ("n_runs", 1), ("restarts", 0)):
            if getattr(self, name) < least:
                raise ValueError(f"{name} must be at least {least}; got {getattr(self, name)}")


class RegionNotReached(ValueError):
    """A run stalled short of the surrogate's acceptance region at every number of designs per level it was given
    (module docstring): the region is empty, or too small or too narrow for the sampler (or the designs near it do
    not converge); SC is then not estimated. ``evaluations``: the misfit evaluations made on the way."""

    def __init__(self, message: str, evaluations: int = 0):
        super().__init__(message)
        self.evaluations = evaluations


class SubsetResult(NamedTuple):
    """Subset simulation of one surrogate I against S structures.

    surrogate: index of I; probability: P(accepted by I); probability_cov: its coefficient of variation;
    probability_lower, probability_upper: its interval at ``level`` (``combined_probability``); run_probabilities:
    (R,) each run's P; levels: (R,) each run's number of levels m + 1 (the last at the target);
    confidence: (S,) SC_IJ; lower, upper: (S,) its interval at ``level``;
    effective_size: (S,) effective sample size of SC_IJ (``family_confidence``); families: the independent level-0
    families the conditional designs descend from (fewer than about 10: the interval rests on few independent
    chains, raise n_per_level); n_conditional: designs drawn given I;
    evaluations: misfit evaluations of single structures (designs x structures), those of stalled runs included;
    designs_per_level: the N every run used (``Settings.n_per_level`` 2^restarts); stalls: why each restart was made
    (the run that stalled, its threshold and lowest misfit); seed.
    """

    surrogate: int
    probability: float
    probability_cov: float
    probability_lower: float
    probability_upper: float
    run_probabilities: np.ndarray
    levels: np.ndarray
    confidence: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    effective_size: np.ndarray
    families: int
    n_conditional: int
    evaluations: int
    designs_per_level: int
    stalls: tuple
    seed: int


def chain_correlation_factor(indicator) -> float:
    """gamma of Au & Beck (2001, Eq. 29) for an indicator (n_chains, length) along Markov chains:
    gamma = 2 sum_{k=1}^{L-1} (1 - k / L) rho_k, rho_k its autocorrelation at lag k estimated over all chains,
    so that Var(mean) = p (1 - p) / n (1 + gamma). Between 0 and L - 1; L - 1 (every chain one design) where the
    indicator is constant and its correlation unknown."""
    values = np.asarray(indicator, dtype=float)
    length = values.shape[1]
    mean = values.mean()
    variance = mean * (1.0 - mean)
    if length == 1:
        return 0.0
    if variance <= 0.0:
        return float(length - 1)
    lags = np.arange(1, length)
    covariance = np.array([np.mean(values[:, :-lag] * values[:, lag:]) - mean ** 2 for lag in lags])
    gamma = 2.0 * np.sum((1.0 - lags / length) * covariance / variance)
    return float(np.clip(gamma, 0.0, length - 1))


def conditional_chains(misfit: Misfit, surrogate: int, seeds, seed_misfit, threshold: float, length: int,
                       scale: float, rng: np.random.Generator):
    """Markov chains in {g_I <= threshold} from ``seeds`` (n_chains, d) in standard normal space with the proposal
    of the module docstring at lambda = ``scale`` (s_i = 1 in a coordinate where the seeds do not differ): returns
    states (n_chains, length, d), their misfits (n_chains, length), the fraction of proposals taken and the
    evaluations made ((length - 1) n_chains)."""
    seeds = np.asarray(seeds, dtype=float)
    n_chains, dimension = seeds.shape
    spread = seeds.std(axis=0, ddof=1) if n_chains > 1 else np.ones(dimension)
    sigma = np.minimum(scale * np.where(spread > 0, spread, 1.0), 1.0)
    states, misfits, taken_count = [seeds], [np.asarray(seed_misfit, dtype=float)], 0
    for _ in range(1, length):
        proposal = np.sqrt(1.0 - sigma ** 2) * states[-1] + sigma * rng.standard_normal((n_chains, dimension))
        proposed = misfit(ndtr(proposal), [surrogate])[:, 0]
        taken = proposed <= threshold
        states.append(np.where(taken[:, None], proposal, states[-1]))
        misfits.append(np.where(taken, proposed, misfits[-1]))
        taken_count += np.count_nonzero(taken)
    evaluations = (length - 1) * n_chains
    return (np.stack(states, axis=1), np.stack(misfits, axis=1), taken_count / max(evaluations, 1), evaluations)


def adapted_scale(scale: float, taken_fraction: float) -> float:
    """lambda of the next level: log lambda + (a - TARGET_ACCEPTANCE), a the fraction of proposals taken."""
    return float(np.exp(np.log(scale) + taken_fraction - TARGET_ACCEPTANCE))


def _choose_seeds(misfits, n_seeds: int, threshold: float, rng: np.random.Generator):
    """The next threshold, the fraction of designs at or below it, and the indices of n_seeds of those designs, for
    a level of designs with ``misfits`` (N,) in {g_I <= threshold} (module docstring): the threshold is the
    n_seeds-th smallest misfit (the seeds chosen at random among ties), or where that equals ``threshold`` the
    largest misfit below it (the seeds drawn from the fewer designs at or below it with replacement), or where no
    design lies below, ``threshold`` itself."""
    following = np.sort(misfits)[n_seeds - 1]
    lower = misfits[misfits < threshold]
    if following >= threshold and lower.size:
        following = lower.max()
    below = np.flatnonzero(misfits <= following)
    chosen = (np.sort(rng.choice(below, n_seeds, replace=below.size < n_seeds)) if below.size != n_seeds
              else below)
    return float(following), below.size / misfits.size, chosen


def stalled(thresholds) -> bool:
    """Whether a run with intermediate thresholds b_1, ..., b_k (``thresholds``) has stalled: b_k fell by less than
    ``STALL_SHARE`` of b_{k - STALL_LEVELS} over the last ``STALL_LEVELS`` levels, or k reached ``MAX_LEVELS``."""
    thresholds = np.asarray(thresholds, dtype=float)
    if thresholds.size >= MAX_LEVELS:
        return True
    return (thresholds.size > STALL_LEVELS
            and not thresholds[-1] < (1.0 - STALL_SHARE) * thresholds[-1 - STALL_LEVELS])


def _state_key(settings: Settings, surrogate: int, dimension: int, problem: str) -> str:
    return sha256_json({"settings": settings._asdict(), "surrogate": surrogate, "dimension": dimension,
                        "problem": problem})


def _save_level(folder: Path | None, key: str, record: dict, states, misfits, families,
                rng: np.random.Generator) -> None:
    """Write one finished level (its designs in standard normal space, misfits, families, the generator's state
    and the record so far) as ``<folder>/level-<k>.json``; nothing where folder is None."""
    if folder is not None:
        write_json(Path(folder) / f"level-{record['level']:03d}.json",
                   {"key": key, **record, "states": states.tolist(), "misfits": misfits.tolist(),
                    "families": families.tolist(), "generator": rng.bit_generator.state})


def _misfits(values) -> np.ndarray:
    """Misfits read back from a level file: null (how strict JSON writes an infinity, ``pipeline.files.write_json``)
    as inf, the misfit of a design that did not converge (``study.errors.scaled_misfit``; a misfit is never NaN)."""
    values = np.array(values, dtype=float)
    return np.where(np.isnan(values), np.inf, values)


def _last_level(folder: Path | None, key: str) -> dict | None:
    """The last saved level of this run in ``folder`` (None where none); levels of another run are refused."""
    if folder is None:
        return None
    paths = sorted(Path(folder).glob("level-*.json"))
    if not paths:
        return None
    record = json.loads(paths[-1].read_text())
    if record.get("key") != key:
        raise ValueError(f"{paths[-1]}: the state of another subset simulation (other settings, surrogate or "
                         "problem); use another state folder")
    return record


class Run(NamedTuple):
    """One run of subset simulation: probability P of acceptance by I and its Au-Beck c.o.v.; thresholds (m + 1,)
    b_k, the last 1; level_probabilities (m + 1,) p_k; acceptance (n, S) of the conditional designs by each
    structure; families (n,) the level-0 design each descends from; evaluations (single structures)."""

    probability: float
    cov: float
    thresholds: np.ndarray
    level_probabilities: np.ndarray
    acceptance: np.ndarray
    families: np.ndarray
    evaluations: int


def subset_simulation(misfit: Misfit, dimension: int, n_structures: int, surrogate: int,
                      settings: Settings = Settings(), level: float = CONFIDENCE_LEVEL,
                      state_folder: Path | None = None, problem: str = "") -> SubsetResult:
    """P(accepted by I) and SC_IJ for every J from ``settings.n_runs`` independent runs of subset simulation
    (module docstring), all with one number of designs per level: N, or where a run stalls, every run again with
    2N, and so on ``settings.restarts`` times at most. P and its interval by ``combined_probability``, SC from the
    conditional designs of every run together, each run's families its own (``family_confidence``).

    misfit: ``Misfit`` over unit designs of ``dimension`` parameters and ``n_structures`` structures; surrogate:
    index of I; level: confidence level of the intervals; state_folder: where each level's state is saved
    (``run-<r>/level-<k>.json``, those of restart a under ``restart-<a>/run-<r>/``) and a killed estimate is
    resumed from (None: nothing saved); problem: a text naming the misfit (its study, model, bounds), part of the
    state's key. Raises RegionNotReached where a run stalls at every number of designs per level.
    """
    settings.check()
    key = _state_key(settings, surrogate, dimension, problem)
    stalls, evaluations = [], 0
    for restart in range(settings.restarts + 1):
        n_per_level = settings.n_per_level * 2 ** restart
        folder = None if state_folder is None else Path(state_folder) / (f"restart-{restart}" if restart else "")
        try:
            runs = [subset_run(misfit, dimension, n_structures, surrogate, n_per_level, settings, run, restart, key,
                               None if folder is None else folder / f"run-{run}")
                    for run in range(settings.n_runs)]
            break
        except RegionNotReached as stall:
            stalls.append(str(stall))
            evaluations += stall.evaluations
    else:
        raise RegionNotReached(f"subset simulation of structure {surrogate}: the region was not reached with "
                               f"{settings.n_per_level} to {n_per_level} designs per level ({settings.restarts} "
                               f"restarts); {stalls[-1]}: the region is empty, or reached only through a passage "
                               "the chains did not find", evaluations)
    probability, cov, probability_lower, probability_upper = combined_probability(
        [run.probability for run in runs], [run.cov for run in runs], level)
    families = np.concatenate([run.families + index * n_per_level for index, run in enumerate(runs)])
    acceptance = np.vstack([run.acceptance for run in runs])
    confidence, lower, upper, effective = family_confidence(acceptance, families, level)
    return SubsetResult(surrogate, probability, cov, probability_lower, probability_upper,
                        np.array([run.probability for run in runs]), np.array([len(run.thresholds) for run in runs]),
                        confidence, lower, upper, effective, int(np.unique(families).size), acceptance.shape[0],
                        evaluations + sum(run.evaluations for run in runs), n_per_level, tuple(stalls), settings.seed)


def combined_probability(probabilities, covs, level: float = CONFIDENCE_LEVEL) -> tuple[float, float, float, float]:
    """P(accepted by I) from R independent runs' estimates P_r: their mean P = mean P_r (each run's estimate is
    unbiased to O(1/N); the mean of their logarithms is low by half the variance of log P_r, which reaches orders
    of magnitude where runs reach a region of several basins through different numbers of levels), its c.o.v.
    c = sd(P_r) / (sqrt(R) P) (the runs' spread, which holds every correlation between levels and chains), and the
    interval P exp(-/+ t s), s = sqrt(log(1 + c^2)) the spread of log P of a log-normal with that c.o.v., t Student's
    quantile on R - 1 degrees of freedom, its upper end at most 1. A single run (R = 1) has c = its Au-Beck c.o.v.
    ``covs`` and the normal quantile."""
    values = np.asarray(probabilities, float)
    runs = values.size
    probability = values.mean()
    cov = np.std(values, ddof=1) / (np.sqrt(runs) * probability) if runs > 1 else float(np.asarray(covs, float)[0])
    spread = np.sqrt(np.log1p(cov ** 2))
    quantile = student_t.ppf(0.5 + level / 2, runs - 1) if runs > 1 else norm.ppf(0.5 + level / 2)
    return (float(probability), float(cov), float(probability * np.exp(-quantile * spread)),
            float(min(1.0, probability * np.exp(quantile * spread))))


def subset_run(misfit: Misfit, dimension: int, n_structures: int, surrogate: int, n_per_level: int,
               settings: Settings, run: int, restart: int, key: str, state_folder: Path | None) -> Run:
    """Run number ``run`` of subset simulation (module docstring) with ``n_per_level`` designs per level: its
    levels (``subset_levels``), then the conditional designs and their acceptance by every structure. Its generator is
    seeded with [seed, run], or [seed, run, restart] in a restart; each finished level is saved in ``state_folder``
    under ``key`` and resumed from there. Raises RegionNotReached (with the evaluations made) where it stalls."""
    rng = np.random.default_rng([settings.seed, run] + [restart] * (restart > 0))
    states, misfits, families, record, stall = subset_levels(misfit, dimension, surrogate, n_per_level,
                                                             settings.level_probability, rng, key, state_folder)
    if stall is not None:
        raise RegionNotReached(f"run {run}: {stall}", record["evaluations"])
    probability, cov = _probability(record["level_probabilities"], record["gammas"], n_per_level)
    accepted = np.flatnonzero(misfits <= 1.0)
    length = -(-settings.n_conditional // accepted.size)
    chains, _, _, used = conditional_chains(misfit, surrogate, states[accepted], misfits[accepted], 1.0, length,
                                            record["scale"], rng)
    others = [structure for structure in range(n_structures) if structure != surrogate]
    conditional = chains.reshape(-1, dimension)
    acceptance = np.ones((conditional.shape[0], n_structures), dtype=bool)
    acceptance[:, others] = misfit(ndtr(conditional), others) <= 1.0
    evaluations = record["evaluations"] + used + conditional.shape[0] * len(others)
    return Run(probability, cov, np.array(record["thresholds"]), np.array(record["level_probabilities"]),
               acceptance, np.repeat(families[accepted], length), int(evaluations))


def subset_levels(misfit: Misfit, dimension: int, surrogate: int, n_per_level: int, level_probability: float,
                  rng: np.random.Generator, key: str, folder: Path | None):
    """The levels of one run of subset simulation (module docstring) with ``n_per_level`` designs each, from
    the prior to {g_I <= 1} or until they stall (``stalled``), each finished level saved in ``folder`` and resumed
    from there. Returns the last level's states (N, d) in standard normal space, misfits (N,) and families (N,), the
    record (thresholds, level_probabilities, gammas, scale, evaluations, chains) and None where the region is
    reached, else why the run stalled."""
    n_seeds = round(n_per_level * level_probability)
    chain_length = round(1.0 / level_probability)
    saved = _last_level(folder, key)
    if saved is None:
        states = rng.standard_normal((n_per_level, dimension))
        misfits = misfit(ndtr(states), [surrogate])[:, 0]
        families = np.arange(n_per_level)
        record = {"level": 0, "thresholds": [], "level_probabilities": [], "gammas": [0.0], "scale": INITIAL_SCALE,
                  "evaluations": n_per_level, "chains": [n_per_level, 1]}
        _save_level(folder, key, record, states, misfits, families, rng)
    else:
        states, families, misfits = np.array(saved["states"]), np.array(saved["families"]), _misfits(saved["misfits"])
        rng.bit_generator.state = saved["generator"]
        record = {name: saved[name] for name in ("level", "thresholds", "level_probabilities", "gammas", "scale",
                                                 "evaluations", "chains")}
        record["thresholds"] = _misfits(record["thresholds"]).tolist()
    while True:
        current = record["thresholds"][-1] if record["thresholds"] else np.inf
        threshold, fraction, chosen = _choose_seeds(misfits, n_seeds, current, rng)
        if threshold <= 1.0:
            final = misfits <= 1.0
            record["thresholds"].append(1.0)
            record["level_probabilities"].append(float(final.mean()))
            record["gammas"][-1] = chain_correlation_factor(final.reshape(record["chains"]))
            return states, misfits, families, record, None
        if stalled([*record["thresholds"], threshold]):
            return states, misfits, families, record, (
                f"the misfit threshold stalled at {threshold:.4g}, the lowest misfit reached {np.min(misfits):.4g} "
                f"(level {record['level'] + 1} with {n_per_level} designs per level)")
        record["thresholds"].append(threshold)
        record["level_probabilities"].append(fraction)
        record["gammas"][-1] = chain_correlation_factor((misfits <= threshold).reshape(record["chains"]))
        chains, chain_misfits, taken, used = conditional_chains(
            misfit, surrogate, states[chosen], misfits[chosen], threshold, chain_length, record["scale"], rng)
        record["scale"] = adapted_scale(record["scale"], taken)
        states, misfits = chains.reshape(-1, dimension), chain_misfits.ravel()
        families = np.repeat(families[chosen], chain_length)
        record["evaluations"] += used
        record["gammas"].append(0.0)
        record["chains"] = [n_seeds, chain_length]
        record["level"] += 1
        _save_level(folder, key, record, states, misfits, families, rng)


def _probability(level_probabilities, gammas, n_per_level: int) -> tuple[float, float]:
    """P = prod p_k and its coefficient of variation sqrt(sum (1 - p_k) / (p_k N) (1 + gamma_k))."""
    p, gamma = np.asarray(level_probabilities), np.asarray(gammas)
    return float(np.prod(p)), float(np.sqrt(np.sum((1.0 - p) / (p * n_per_level) * (1.0 + gamma))))


def family_confidence(acceptance, families, level: float = CONFIDENCE_LEVEL):
    """SC_IJ (S,) from the acceptance (n, S) of conditional designs by each structure, its Clopper-Pearson interval
    at the effective sample size, and that size (S,).

    families: (n,) the level-0 design each conditional design descends from; designs of different families are
    independent (their chains never met), those of one family are not. With y_b and n_b the accepted count and
    size of family b (B families), SC = sum y_b / sum n_b and, as a ratio estimator over independent families,
    Var(SC) = B / (B - 1) sum (y_b - SC n_b)^2 / n^2; the effective size is SC (1 - SC) / Var(SC) between B and n,
    and B (each family counts as one design) where fewer than MIN_MINORITY_FAMILIES families hold a design of the
    minority outcome (the variance of a rare outcome seen in one or two families is not estimable), times
    (z / t_{B-1})^2 so that the interval widens as Student's t does for a variance estimated from B families."""
    acceptance = np.asarray(acceptance, dtype=float)
    _, family = np.unique(families, return_inverse=True)
    n_families, n = family.max() + 1, acceptance.shape[0]
    sizes = np.bincount(family, minlength=n_families).astype(float)
    counts = np.stack([np.bincount(family, weights=column, minlength=n_families) for column in acceptance.T], axis=1)
    confidence = counts.sum(axis=0) / n
    deviations = np.sum((counts - confidence * sizes[:, None]) ** 2, axis=0)
    variance = n_families / max(n_families - 1, 1) * deviations / n ** 2
    binomial = confidence * (1.0 - confidence)
    minority = np.where(confidence > 0.5, counts < sizes[:, None], counts > 0)  # (B, S) families holding one
    estimable = (variance > 0) & (np.count_nonzero(minority, axis=0) >= MIN_MINORITY_FAMILIES)
    effective = np.where(estimable, binomial / np.where(estimable, variance, 1.0), n_families)
    effective = np.clip(effective, n_families, n)
    if n_families > 1:  # the variance from B families has B - 1 degrees of freedom: Student's t for the normal
        effective = effective * (norm.ppf(0.5 + level / 2) / student_t.ppf(0.5 + level / 2, n_families - 1)) ** 2
    lower, upper = proportion_confint(confidence * effective, effective, alpha=1.0 - level, method=INTERVAL_METHOD)
    return confidence, np.asarray(lower, float), np.asarray(upper, float), effective


def structure_bounds(exploration: Exploration, frequency_tolerance_hz, damping_tolerance) -> np.ndarray:
    """(k, 2) acceptance bounds (Hz, -) of the study's k structures: one value for all, or one per structure."""
    bounds = np.column_stack([np.broadcast_to(np.asarray(value, dtype=float), (len(exploration.names),))
                              for value in (frequency_tolerance_hz, damping_tolerance)])
    if not np.all(bounds > 0):
        raise ValueError(f"acceptance bounds {bounds.tolist()}: expected positive values")
    return bounds


def study_misfit(exploration: Exploration, model: str, case: str, frequency_tolerance_hz,
                 damping_tolerance, runner=SERIAL) -> Misfit:
    """The ``Misfit`` of a study's structures (``scaled_errors``) with linear damping case ``case`` and
    acceptance bounds (Hz, -) the same for every structure or one per structure (``structure_bounds``), evaluated
    on ``runner`` (``pipeline.runners``), each batch cut into one piece per slot (a design's errors do not depend on
    the batch it is evaluated in, so the numbers are the serial ones)."""
    if case not in exploration.damping_cases:
        raise ValueError(f"damping case {case!r}: not a case of this study; expected one of "
                         f"{list(exploration.damping_cases)}")
    column = list(exploration.damping_cases).index(case)
    bounds = structure_bounds(exploration, frequency_tolerance_hz, damping_tolerance)
    shared = runner.share(exploration)

    def misfit(unit, structures):
        parts = np.array_split(unit, max(1, min(runner.slots, len(unit))))  # none empty, one where unit is
        return np.vstack(runner.map(scaled_errors, [(shared, model, column, bounds, part, list(structures))
                                                    for part in parts]))

    return misfit


def scaled_errors(exploration: Exploration, model: str, column: int, bounds: np.ndarray, unit,
                  structures) -> np.ndarray:
    """Scaled misfits (n, k) of unit designs (n, d) on the structures indexed by ``structures`` (k,): the designs
    mapped by Table 3 (``nonlinear.joint.from_unit``), evaluated by the exploration's own evaluation
    (``study.exploration.structure_errors``, the structures' modal splits formed once per process), the damping
    error of case number ``column``, scaled by each structure's ``bounds`` ((k_all, 2), Hz and -;
    ``study.errors.scaled_misfit``)."""
    designs = from_unit(unit, *parameter_limits(model, exploration.n_groups))
    errors = structure_errors(exploration, model, designs, process_splits(exploration), list(structures))
    return np.column_stack([scaled_misfit(error.frequency_error_hz, error.damping_error[:, column], *bounds[index])
                            for index, error in zip(structures, errors)])


def study_subset_simulation(exploration: Exploration, model: str, surrogate: str, case: str,
                            frequency_tolerance_hz, damping_tolerance, settings: Settings = Settings(),
                            state_folder: Path | None = None, runner=SERIAL) -> SubsetResult:
    """``subset_simulation`` of one friction model's designs with ``surrogate`` (a structure's name) as I, at the
    acceptance bounds frequency_tolerance_hz (Hz) and damping_tolerance (-), each one value or one per structure;
    evaluations on ``runner`` (``study_misfit``)."""
    if surrogate not in exploration.names:
        raise ValueError(f"surrogate {surrogate!r}: not a structure of this study; expected one of {exploration.names}")
    if model not in exploration.models:
        raise ValueError(f"model {model!r}: not a friction model of this study; expected one of {exploration.models}")
    problem = json.dumps({"study_key": exploration.key(), "model": model, "case": case,
                          "bounds": structure_bounds(exploration, frequency_tolerance_hz,
                                                     damping_tolerance).tolist()})
    misfit = study_misfit(exploration, model, case, frequency_tolerance_hz, damping_tolerance, runner)
    return subset_simulation(misfit, len(parameter_limits(model, exploration.n_groups)[0]), len(exploration.names),
                             exploration.names.index(surrogate), settings, state_folder=state_folder, problem=problem)


SUBSET_COLUMNS = ("model", "surrogate", "real", "confidence", "lower", "upper", "effective_size", "families",
                  "surrogate_probability", "surrogate_probability_cov", "surrogate_probability_lower",
                  "surrogate_probability_upper", "frequency_tolerance_hz", "damping_tolerance",
                  "surrogate_frequency_tolerance_hz", "surrogate_damping_tolerance", "sample_confidence",
                  "sample_lower", "sample_upper", "sample_accepted_surrogate", "runs", "designs_per_level",
                  "n_conditional", "evaluations", "seed", "note")


def subset_table(result: SubsetResult | None, model: str, structures: Sequence[str], frequency_tolerance_hz,
                 damping_tolerance, sample=None, surrogate: int | None = None, note: str = "") -> pd.DataFrame:
    """One row per real structure J (``SUBSET_COLUMNS``): SC_IJ with its interval and effective sample size, and
    the surrogate's P(accepted by I) with its c.o.v. and interval, J's and I's bounds (each one value or one per
    structure), SC_IJ counted on a sample at the same bounds where ``sample`` (a ``study.surrogacy``
    SurrogacyMatrix) is given (NaN otherwise), the designs per level the runs used (N, or 2^k N after k restarts),
    the evaluations, the seed, and in ``note`` the stalls that made the restarts. Without a ``result`` (the region
    not reached) the estimate's columns are NaN, ``surrogate`` says which structure I is and ``note`` why."""
    bounds = np.column_stack([np.broadcast_to(np.asarray(value, dtype=float), (len(structures),))
                              for value in (frequency_tolerance_hz, damping_tolerance)])
    row = result.surrogate if result is not None else surrogate
    missing = np.full(len(structures), np.nan)

    def estimate(name):
        return np.nan if result is None else getattr(result, name)

    return pd.DataFrame({
        "model": model, "surrogate": structures[row], "real": list(structures),
        "confidence": estimate("confidence"), "lower": estimate("lower"), "upper": estimate("upper"),
        "effective_size": estimate("effective_size"), "families": estimate("families"),
        "surrogate_probability": estimate("probability"), "surrogate_probability_cov": estimate("probability_cov"),
        "surrogate_probability_lower": estimate("probability_lower"),
        "surrogate_probability_upper": estimate("probability_upper"), "frequency_tolerance_hz": bounds[:, 0],
        "damping_tolerance": bounds[:, 1], "surrogate_frequency_tolerance_hz": bounds[row, 0],
        "surrogate_damping_tolerance": bounds[row, 1],
        "sample_confidence": missing if sample is None else sample.confidence[row],
        "sample_lower": missing if sample is None else sample.lower[row],
        "sample_upper": missing if sample is None else sample.upper[row],
        "sample_accepted_surrogate": -1 if sample is None else int(sample.accepted_counts[row]),
        "runs": np.nan if result is None else len(result.run_probabilities),
        "designs_per_level": estimate("designs_per_level"),
        "n_conditional": estimate("n_conditional"),
        "evaluations": estimate("evaluations"), "seed": estimate("seed"),
        "note": note if result is None else "; ".join(f"restarted with twice the designs per level: {stall}"
                                                      for stall in result.stalls)}, columns=list(SUBSET_COLUMNS))


def write_subset_csv(table: pd.DataFrame, destination: Path) -> None:
    """Write ``subset_table`` as CSV (full precision), atomically."""
    with atomic_path(destination) as temporary:
        table.to_csv(temporary, index=False, columns=list(SUBSET_COLUMNS))
