"""The ring-down (free decay) record: one type for measured files and simulated decays alike.

The file readers (:mod:`experiment.ringdown_files`) and the transient simulation of the jointed model
(:func:`nonlinear.transient.ring_down`) both produce :class:`RingDown`, and
:func:`experiment.backbone.ringdown_backbone` turns a list of them into a backbone.

Layout: channels along the first axis, samples along the last, ``signals`` (n_channels, n_samples), so that
the sensor signals are y = Phi q sample by sample ((n_channels, n_modes) @ (n_modes, n_samples)) and SciPy's
filters run along the last axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

DISPLACEMENT_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
"""Quantity a ring-down may hold -> number of time derivatives between displacement and it: a displacement
amplitude is the signal amplitude divided by omega^order."""


class RingDownError(ValueError):
    """A ring-down that cannot be used: names its source (a file, or a simulation), the field (or record)
    and the problem."""

    def __init__(self, source: str | Path, field: str, problem: str):
        self.source, self.field, self.problem = str(source), field, problem
        super().__init__(f"{source}: field '{field}': {problem}")


@dataclass(frozen=True)
class RingDown:
    """One hit of a free decay, sampled uniformly.

    time: (n_samples,) s, strictly increasing. signals: (n_channels, n_samples) in SI units of ``quantity``
    (m, m/s or m/s^2). channels: n_channels sensor names. quantity: a key of :data:`DISPLACEMENT_ORDER`.
    source: where the record came from (file path or a description of the simulation), for messages.
    hit: label of the hit within the source.
    """

    time: np.ndarray
    signals: np.ndarray
    channels: tuple[str, ...]
    quantity: str
    source: str
    hit: str

    def __post_init__(self):
        if self.quantity not in DISPLACEMENT_ORDER:
            raise RingDownError(self.source, "quantity", f"'{self.quantity}' is not one of "
                                                         f"{sorted(DISPLACEMENT_ORDER)}")
        if np.shape(self.signals) != (len(self.channels), np.size(self.time)):
            raise RingDownError(self.source, "signals", f"shape {np.shape(self.signals)} is not (n_channels, "
                                                        f"n_samples) = ({len(self.channels)}, {np.size(self.time)})")

    @property
    def sample_rate(self) -> float:
        """Sampling frequency, Hz."""
        return (len(self.time) - 1) / (self.time[-1] - self.time[0])


def selected_channels(ring_down: RingDown, channels: list[str]) -> RingDown:
    """The ring-down restricted to the named channels, in that order."""
    missing = sorted(set(channels) - set(ring_down.channels))
    if missing:
        raise RingDownError(ring_down.source, ", ".join(missing), f"no such channel (the record has "
                                                                  f"{ring_down.channels})")
    rows = [ring_down.channels.index(name) for name in channels]
    return RingDown(ring_down.time, ring_down.signals[rows], tuple(channels), ring_down.quantity, ring_down.source,
                    ring_down.hit)
