"""Held-out challenge-like ring-downs (virtual) for the discrepancy loop: the challenge set's reference backbone
(``ringdown-challenge/reference_backbone.csv`` beside the project) with the key's kinds of effect outside the joint
at other sizes and noise seeds, in the challenge's layout (``benchmarks.second_mode.challenge_like_clean`` and
``challenge_like_hits``), so that the loop is checked on files of that generator's kind that no test tunes it to.

Effects, applied to the reference's omega(q) and zeta(q) at every instant of the envelope equations, with q_top =
1.8406e-4 m kg^0.5 (the challenge README's amplitude of the 2 % drop): mass loading omega / sqrt(m), cubic
stiffening omega (1 + k q^2) with k q_top^2 = ``stiffening``, amplitude damping zeta + c q with c q_top = ``rise``
zeta_ref(q_top), linear damping zeta + ``added_zeta``; and the two kinds outside any one-mode library
(``HIT_EFFECTS``, the challenge's P6 and P7 kinds): a second mode (``second``: its frequency over the reference's
lowest-amplitude one, its displacement envelope's share of the target's) and a drift of the frequency within each
hit (``drift``: its relative fall over the 1.65 s decay). Each file's CSV says only that it is virtual; its truth is
in ``key.json`` beside the files (case -> effects and seed).

Run: ``python -m benchmarks.held_out OUT [CASE ...]``; then ``surrogacy freevib OUT/CASE.csv --mode-hz 170`` and
``surrogacy discrepancy BACKBONE`` as a user runs them.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.second_mode import (CHALLENGE_BACKBONE, challenge_like_clean, challenge_like_hits, log_amplitude_law,
                                    read_backbone_table)
from experiment.ringdown_files import write_ringdown_csv
from pipeline.files import atomic_path

Q_TOP = 1.8406e-4  # m kg^0.5, the challenge README's amplitude of the reference's 2 % frequency drop

CASES = {
    **{f"clean{seed}": ({}, seed) for seed in range(41, 47)},
    "m1.007k.004s11": ({"mass": 1.007, "stiffening": 0.004}, 11),
    "m1.007k.004s12": ({"mass": 1.007, "stiffening": 0.004}, 12),
    "m1.007k.004s13": ({"mass": 1.007, "stiffening": 0.004}, 13),
    "k.004s11": ({"stiffening": 0.004}, 11), "k.006s12": ({"stiffening": 0.006}, 12),
    "m1.010k.006s11": ({"mass": 1.010, "stiffening": 0.006}, 11),
    "m1.004k.003s11": ({"mass": 1.004, "stiffening": 0.003}, 11), "m1.012s47": ({"mass": 1.012}, 47),
    "z.6e-3s48": ({"added_zeta": 6e-4}, 48), "c.3s49": ({"rise": 0.3}, 49),
    "c.7m1.008s50": ({"rise": 0.7, "mass": 1.008}, 50),
    "k.004s21": ({"stiffening": 0.004}, 21), "k.004s22": ({"stiffening": 0.004}, 22),
    "k.005s23": ({"stiffening": 0.005}, 23), "m1.005k.005s24": ({"mass": 1.005, "stiffening": 0.005}, 24),
    "c.4s25": ({"rise": 0.4}, 25), "c.5m1.01s26": ({"rise": 0.5, "mass": 1.01}, 26),
    "k.003s31": ({"stiffening": 0.003}, 31), "k.0025s32": ({"stiffening": 0.0025}, 32),
    "z.2e-4s33": ({"added_zeta": 2e-4}, 33), "c.2s34": ({"rise": 0.2}, 34),
    "z.3e-4c.4s35": ({"added_zeta": 3e-4, "rise": 0.4}, 35), "m1.02s36": ({"mass": 1.02}, 36),
    "m1.005k.003s37": ({"mass": 1.005, "stiffening": 0.003}, 37), "k.010s38": ({"stiffening": 0.010}, 38),
    "c.8s39": ({"rise": 0.8}, 39), "m1.003z.3e-4s40": ({"mass": 1.003, "added_zeta": 3e-4}, 40),
    "z.5e-4k.006s51": ({"added_zeta": 5e-4, "stiffening": 0.006}, 51),
    "c.5k.006s52": ({"rise": 0.5, "stiffening": 0.006}, 52),
    "m1.01z.5e-4c.5s53": ({"mass": 1.01, "added_zeta": 5e-4, "rise": 0.5}, 53),
    "d.7e-3s54": ({"drift": 7e-4}, 54), "d2e-3s55": ({"drift": 2e-3}, 55), "d-1e-3s56": ({"drift": -1e-3}, 56),
    "d1e-3k.006s57": ({"drift": 1e-3, "stiffening": 0.006}, 57),
    "d1e-3m1.01s58": ({"drift": 1e-3, "mass": 1.01}, 58),
    "f1.03a.1s59": ({"second": (1.03, 0.10)}, 59), "f1.06a.2s60": ({"second": (1.06, 0.20)}, 60),
    "f1.04a.15k.006s61": ({"second": (1.04, 0.15), "stiffening": 0.006}, 61),
    "f1.05a.1c.5s62": ({"second": (1.05, 0.10), "rise": 0.5}, 62),
}
"""Case -> (effects outside the joint, noise seed)."""
HIT_EFFECTS = ("second", "drift")
"""The effects made by the hits' generator (``challenge_like_clean``), not by the backbone's laws."""


def effect_laws(backbone, mass: float = 1.0, stiffening: float = 0.0, rise: float = 0.0, added_zeta: float = 0.0):
    """(omega (rad/s), zeta) as functions of ln q: the reference ``backbone`` (``read_backbone_table``) with the
    effects of the module docstring."""
    q, _, omega, zeta = backbone
    omega_ref, zeta_ref = log_amplitude_law(q, omega), log_amplitude_law(q, zeta)
    per_q = rise * zeta_ref(np.log(Q_TOP)) / Q_TOP
    per_q2 = stiffening / Q_TOP ** 2

    def omega_of(log_q):
        return omega_ref(log_q) / np.sqrt(mass) * (1 + per_q2 * np.exp(2 * log_q))

    def zeta_of(log_q):
        return zeta_ref(log_q) + added_zeta + per_q * np.exp(log_q)
    return omega_of, zeta_of


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder of the ring-down CSVs and key.json")
    parser.add_argument("cases", nargs="*", default=list(CASES), help="cases to write (all by default)")
    arguments = parser.parse_args(argv)
    unknown = [case for case in arguments.cases if case not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {unknown}: expected names of benchmarks.held_out.CASES")
    backbone = read_backbone_table(CHALLENGE_BACKBONE)
    arguments.out.mkdir(parents=True, exist_ok=True)
    for case in arguments.cases:
        effects, seed = CASES[case]
        laws = effect_laws(backbone, **{name: size for name, size in effects.items() if name not in HIT_EFFECTS})
        hits = challenge_like_hits(challenge_like_clean(backbone, laws=laws, **{name: effects[name] for name in
                                                                                HIT_EFFECTS if name in effects}), seed)
        write_ringdown_csv(hits, arguments.out / f"{case}.csv", comment="virtual challenge-like hammer ring-downs "
                           "(benchmarks.held_out)", provenance="virtual")
        print(f"wrote {arguments.out / case}.csv", flush=True)
    with atomic_path(arguments.out / "key.json") as temporary:
        Path(temporary).write_text(json.dumps({case: {"effects": CASES[case][0], "seed": CASES[case][1]}
                                               for case in CASES}, indent=1))


if __name__ == "__main__":
    main()
