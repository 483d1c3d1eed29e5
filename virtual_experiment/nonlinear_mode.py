"""One joint design's nonlinear mode by harmonic balance (EPMC, ``nonlinear.epmc``) beside its QSMA backbone, on a
superelement, written as two virtual backbones at the same modal amplitudes (``surrogacy epmc``).

The mode followed is a tied mode of the superelement (1: the first elastic mode with every joint motion tied). The
amplitudes are log-spaced multiples of the design's slip amplitude (the modal amplitude at which its first element
reaches macroslip in the stuck mode, ``nonlinear.epmc.slip_amplitude``), from stuck into macroslip. Neither method
has linear damping. A level a method did not reach (a corrector that failed, a level QSMA flags) is left out of
that method's backbone.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from experiment.backbone import Backbone, ModeBackbone
from experiment.backbone_files import write_backbone
from nonlinear.condensation import joint_space
from nonlinear.epmc import HARMONICS, SAMPLES, ModeComparison, compare_with_qsma, slip_amplitude
from pipeline.files import stage_folder
from reduction.superelement import (TIED_MODES, Superelement, beam_superelement, read_asb_superelement,
                                   stuck_joint_modes)

METHODS = ("epmc", "qsma")
"""The two methods compared, as they name their backbone files."""


def read_superelement(path: Path) -> Superelement:
    """The superelement in ``path``, by its suffix: a beam's ``.npz`` (``surrogacy rom``) or an ASB ``.mat``
    (``MAT_NULLRED_<configuration>.mat``). ValueError naming the file where it is neither."""
    path = Path(path)
    if path.suffix == ".npz":
        return beam_superelement(path)
    if path.suffix == ".mat":
        return read_asb_superelement(path)
    raise ValueError(f"{path}: expected a .npz (surrogacy rom) or an ASB .mat superelement")


class ModeFollowed(NamedTuple):
    """A design's nonlinear mode beside its QSMA backbone.

    amplitudes: (levels,) modal amplitudes, m kg^0.5; slip: the design's slip amplitude, m kg^0.5; comparison: EPMC
    and QSMA at those amplitudes with the harmonic count chosen (``nonlinear.epmc.ModeComparison``; circular
    frequencies rad/s, damping ratios); seconds: the wall time of the comparison, s.
    """

    amplitudes: np.ndarray
    slip: float
    comparison: ModeComparison
    seconds: float

    def reached(self, method: str) -> np.ndarray:
        """(levels,) bool: the levels ``method`` ("epmc" or "qsma") reached."""
        return (self.comparison.mode if method == "epmc" else self.comparison.qsma).converged

    def curve(self, method: str) -> tuple[np.ndarray, np.ndarray]:
        """``method``'s circular frequency (rad/s) and damping ratio at every level."""
        solution = self.comparison.mode if method == "epmc" else self.comparison.qsma
        return solution.frequency, solution.damping


def follow_mode(superelement: Superelement, model: str, design, mode: int = 1, start: float = 0.05,
                stop: float = 20.0, levels: int = 12, harmonics: int | None = None,
                samples: int = SAMPLES) -> ModeFollowed:
    """EPMC and QSMA of ``design`` (the model's parameters in its order, N and N/m) along tied mode ``mode``, at
    ``levels`` amplitudes from ``start`` to ``stop`` slip amplitudes; ``harmonics`` fixed, or chosen by the
    convergence check over ``nonlinear.epmc.HARMONICS``; ``samples`` per period of the AFT time loop. ValueError
    naming the argument where one is out of range, or where no tangential element of the design moves in the mode
    or can slip (nothing to follow)."""
    if not 1 <= mode <= TIED_MODES:
        raise ValueError(f"mode = {mode}: expected a tied mode from 1 to {TIED_MODES}")
    if not 0 < start < stop or levels < 2:
        raise ValueError(f"amplitudes from {start} to {stop} slip amplitudes at {levels} levels: expected "
                         "0 < from < to and at least 2 levels")
    if harmonics is not None and not 1 <= harmonics < samples / 2:
        raise ValueError(f"harmonics = {harmonics}: expected 1 to fewer than half of the samples ({samples})")
    space = joint_space(superelement, reference_mode=stuck_joint_modes(superelement, mode)[1][:, -1])
    slip = slip_amplitude(space, model, design)
    if not np.isfinite(slip):
        raise ValueError(f"the {model} design: no tangential element moves in the mode or can slip; nothing to "
                         "follow")
    amplitudes = slip * np.geomspace(start, stop, levels)
    started = time.perf_counter()
    comparison = compare_with_qsma(space, model, design, amplitudes,
                                   HARMONICS if harmonics is None else (harmonics,), samples)
    return ModeFollowed(amplitudes, slip, comparison, time.perf_counter() - started)


def method_backbone(followed: ModeFollowed, method: str, name: str, source: str) -> ModeBackbone:
    """``method``'s virtual backbone at the levels it reached: frequency (Hz) and damping ratio against modal
    amplitude (m kg^0.5); EPMC's settings (harmonics, samples per period, whether the harmonics converged, slip
    amplitude) recorded with it."""
    kept = followed.reached(method)
    frequency, damping = (values[kept] for values in followed.curve(method))
    unknown = np.full(int(kept.sum()), np.nan)
    curve = Backbone(followed.amplitudes[kept], frequency / (2 * np.pi), unknown, unknown, damping, unknown, unknown,
                     np.ones(int(kept.sum()), dtype=int))
    mode = followed.comparison.mode
    settings = {"harmonics": mode.harmonics, "samples": mode.samples,
                "harmonics_converged": followed.comparison.harmonics.converged,
                "slip_amplitude": followed.slip} if method == "epmc" else {}
    return ModeBackbone(f"{name} ({method})", float(frequency[0] / (2 * np.pi)), "m kg^0.5", "virtual", source,
                        curve, settings)


def write_backbones(followed: ModeFollowed, out: Path, stem: str, name: str, source: str) -> dict[str, Path | None]:
    """Each method's backbone as ``<out>/<stem>_<method>.csv`` (docs/formats.md; labelled virtual), in the stage
    folder ``out``; a method that reached no level writes nothing. Returns method -> its file (None: none)."""
    written = {}
    with stage_folder(out):
        for method in METHODS:
            path = Path(out) / f"{stem}_{method}.csv" if followed.reached(method).any() else None
            if path is not None:
                write_backbone(method_backbone(followed, method, name, source), path)
            written[method] = path
    return written
