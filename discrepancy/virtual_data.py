"""Data with undeclared effects, to test the discrepancy loop: a measured-looking backbone or ring-down of a
structure's mode with a reference joint plus library effects plus measurement noise, written as a backbone CSV or
a ring-down CSV that says only that it is virtual (never what was put in). The truth stays with the caller.

Backbone: the one-mode model (``discrepancy.loop.model_backbone``) at log-spaced modal amplitudes, with Gaussian
noise of standard deviation ``frequency_noise`` times the frequency and ``damping_noise`` times the damping,
stated in the file as the points' standard errors (as FreeVib states its estimates' noise).

Ring-down: the free decay of the same backbone by the averaged (slow-flow) equations of a weakly damped
oscillator with amplitude-dependent frequency and damping, da/dt = -zeta(a) omega(a) a, dphi/dt = omega(a),
sampled as the mode's displacement a cos(phi) (one sensor of unit mode shape, so its amplitude in m is the modal
amplitude in m kg^0.5), with white sensor noise ``noise_db`` below the initial amplitude. A user's ring-down
processed by FreeVib (``experiment.ringdown_backbone``) gives the backbone back, so the loop sees the effects
through the whole measurement path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from experiment.backbone import Backbone, ModeBackbone
from experiment.backbone_files import ASB_MODAL_AMPLITUDE_UNIT, write_backbone
from experiment.ringdown import RingDown
from experiment.ringdown_files import write_ringdown_csv
from discrepancy.loop import EFFECTS, model_backbone

REFERENCE_FREQUENCY_HZ = 169.48  # the BRB's Table 1 frequency and damping
REFERENCE_DAMPING = 1.666e-3
REFERENCE_JOINT = {"kappa": 0.15, "slip_force": 0.15 * (2 * np.pi * REFERENCE_FREQUENCY_HZ) ** 2 * 5e-5}
AMPLITUDES = np.geomspace(5e-6, 3e-4, 20)  # m kg^0.5: stuck to well into macroslip of the reference joint
# One instance of each library effect, large enough to matter at the study's tolerances, small enough to be real.
EFFECT_INSTANCES = {"microslip": {"chi": -0.4, "beta": 0.2}, "stiction": {"theta": 0.6},
                    "linear_damping": {"zeta_0": 3.5e-3}, "amplitude_damping": {"air_damping": 2e-3},
                    "stiffness_change": {"frequency_shift": -0.01}, "cubic_stiffening": {"cubic": 0.01}}
assert set(EFFECT_INSTANCES) == set(EFFECTS)


def true_backbone(effects=(), outside_library=None, amplitudes=AMPLITUDES):
    """Frequency (Hz) and damping (n,) of the reference joint with ``effects`` (names of the library) put in and
    optionally an effect outside the library (a function of amplitude returning a frequency offset in Hz)."""
    parameters = dict(REFERENCE_JOINT)
    for effect in effects:
        parameters.update(EFFECT_INSTANCES[effect])
    frequency, damping = model_backbone(parameters, amplitudes, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING)
    if outside_library is not None:
        frequency = frequency + outside_library(amplitudes)
    return frequency, damping


def undeclared_backbone(effects=(), seed: int = 0, frequency_noise: float = 2e-4, damping_noise: float = 0.03,
                        outside_library=None, amplitudes=AMPLITUDES) -> ModeBackbone:
    """The reference joint's backbone with ``effects`` and seeded noise (module docstring)."""
    frequency, damping = true_backbone(effects, outside_library, amplitudes)
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


def undeclared_ringdown(effects=(), seed: int = 0, noise_db: float = 60.0, sample_rate_hz: float = 4096.0,
                        duration_s: float = 4.0) -> RingDown:
    """The free decay of the reference joint's backbone with ``effects`` from the largest amplitude of
    ``AMPLITUDES`` (module docstring): one displacement channel, seeded noise."""
    grid = np.geomspace(AMPLITUDES[0] / 20, AMPLITUDES[-1], 400)  # the effects scale with AMPLITUDES[-1]
    frequency, damping = true_backbone(effects, amplitudes=grid)
    omega, log_grid = 2 * np.pi * frequency, np.log(grid)

    def slow_flow(_, state):  # state: log amplitude, phase
        omega_now = np.interp(state[0], log_grid, omega)
        return [-np.interp(state[0], log_grid, damping) * omega_now, omega_now]

    time = np.arange(0.0, duration_s, 1.0 / sample_rate_hz)
    # tight: the phase after ~700 periods must be right to far below the sensor noise's 1e-3 of the amplitude
    flow = solve_ivp(slow_flow, (0.0, duration_s), [np.log(AMPLITUDES[-1]), 0.0], t_eval=time, rtol=1e-10,
                     atol=1e-12, method="DOP853")
    displacement = np.exp(flow.y[0]) * np.cos(flow.y[1])
    rng = np.random.default_rng(seed)
    noise = AMPLITUDES[-1] * 10 ** (-noise_db / 20) * rng.standard_normal(time.size)
    return RingDown(time, (displacement + noise)[None, :], ("sensor",), "displacement",
                    f"virtual ring-down for the discrepancy loop (seed {seed})", "1")


def write_undeclared_ringdown(destination: Path, effects=(), seed: int = 0, **options) -> None:
    """Write :func:`undeclared_ringdown` as a ring-down CSV (the effects appear nowhere in the file)."""
    ring_down = undeclared_ringdown(effects, seed, **options)
    write_ringdown_csv([ring_down], Path(destination), comment=f"VIRTUAL data: {ring_down.source}")
