"""Data with undeclared effects, to test the discrepancy loop: a measured-looking backbone of a structure's mode
with a reference joint plus library effects plus measurement noise, written as a backbone CSV whose header says
only that it is virtual (never what was put in). The truth is returned to the caller, who keeps it apart.

The backbone is the one-mode model (``study.discrepancy.model_backbone``) at log-spaced modal amplitudes, with
Gaussian noise of standard deviation ``frequency_noise`` times the frequency and ``damping_noise`` times the
damping, stated in the file as the points' standard errors (as FreeVib states its estimates' noise).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiment.backbone import Backbone, ModeBackbone
from experiment.backbone_files import ASB_MODAL_AMPLITUDE_UNIT, write_backbone
from study.discrepancy import EFFECTS, model_backbone

REFERENCE_FREQUENCY_HZ = 169.48  # the BRB's Table 1 frequency and damping
REFERENCE_DAMPING = 1.666e-3
REFERENCE_JOINT = {"kappa": 0.15, "slip_force": 0.15 * (2 * np.pi * REFERENCE_FREQUENCY_HZ) ** 2 * 5e-5}
AMPLITUDES = np.geomspace(5e-6, 3e-4, 20)  # m kg^0.5: stuck to well into macroslip of the reference joint
# One instance of each library effect, large enough to matter at the study's tolerances, small enough to be real.
EFFECT_INSTANCES = {"microslip": {"chi": -0.4, "beta": 0.2}, "stiction": {"theta": 0.6},
                    "linear_damping": {"zeta_0": 3.5e-3}, "amplitude_damping": {"air_damping": 2e-3},
                    "stiffness_change": {"frequency_shift": -0.01}, "cubic_stiffening": {"cubic": 0.01}}
assert set(EFFECT_INSTANCES) == set(EFFECTS)


def undeclared_backbone(effects=(), seed: int = 0, frequency_noise: float = 2e-4, damping_noise: float = 0.03,
                        outside_library=None, amplitudes=AMPLITUDES) -> ModeBackbone:
    """The reference joint's backbone with ``effects`` (names of the library) put in, optionally an effect
    outside the library (a function of amplitude returning a frequency offset in Hz), and seeded noise."""
    parameters = dict(REFERENCE_JOINT)
    for effect in effects:
        parameters.update(EFFECT_INSTANCES[effect])
    frequency, damping = model_backbone(parameters, amplitudes, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING)
    if outside_library is not None:
        frequency = frequency + outside_library(amplitudes)
    rng = np.random.default_rng(seed)
    frequency_error, damping_error = frequency_noise * frequency, damping_noise * damping
    unknown = np.full(len(amplitudes), np.nan)
    backbone = Backbone(np.asarray(amplitudes, float), frequency + frequency_error * rng.standard_normal(frequency.size),
                        unknown, frequency_error, damping + damping_error * rng.standard_normal(damping.size),
                        unknown, damping_error, np.ones(len(amplitudes), dtype=int))
    return ModeBackbone("virtual structure", float(backbone.natural_frequency_hz[0]), ASB_MODAL_AMPLITUDE_UNIT,
                        "virtual", f"virtual backbone for the discrepancy loop (seed {seed})", backbone)


def write_undeclared_backbone(destination: Path, effects=(), seed: int = 0, **options) -> None:
    """Write :func:`undeclared_backbone` as a backbone CSV (the effects appear nowhere in the file)."""
    write_backbone(undeclared_backbone(effects, seed, **options), Path(destination))
