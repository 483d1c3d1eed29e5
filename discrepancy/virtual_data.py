"""Data with undeclared effects, to test the discrepancy loop: a measured-looking backbone or ring-down of a
structure's mode with a reference joint plus library effects plus measurement noise, written as a backbone CSV or
a ring-down CSV that says only that it is virtual (never what was put in). The truth stays with the caller.

Backbone: the one-mode model (``discrepancy.loop.model_backbone``) at log-spaced modal amplitudes, with Gaussian
noise of standard deviation ``frequency_noise`` times the frequency and ``damping_noise`` times the damping,
stated in the file as the points' standard errors (as FreeVib states its estimates' noise).

Ring-down: the free decay of the same backbone by the averaged (slow-flow) equations of a weakly damped
oscillator with amplitude-dependent frequency and damping, da/dt = -zeta(a) omega(a) a, dphi/dt = omega(a),
sampled as the mode's displacement a cos(phi) (one sensor of unit mode shape, so its amplitude in m is the modal
amplitude in m kg^0.5), with white sensor noise ``noise_db`` below the initial amplitude. Content outside any
backbone, for the signal checks (``experiment.signal_checks``): several hits with a pre-trigger, a second close
mode, a drift of the frequency over the hits or within each hit (:func:`undeclared_ringdown`). A user's ring-down
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
from discrepancy.effects import EFFECTS
from discrepancy.loop import model_backbone

REFERENCE_FREQUENCY_HZ = 169.48  # the BRB's Table 1 frequency and damping
REFERENCE_DAMPING = 1.666e-3
REFERENCE_JOINT = {"kappa": 0.15, "slip_force": 0.15 * (2 * np.pi * REFERENCE_FREQUENCY_HZ) ** 2 * 5e-5}
AMPLITUDES = np.geomspace(5e-6, 3e-4, 20)  # m kg^0.5: stuck to well into macroslip of the reference joint


def true_backbone(effects=(), outside_library=None, amplitudes=AMPLITUDES):
    """Frequency (Hz) and damping (n,) of the reference joint with ``effects`` (names of the library) put in and
    optionally an effect outside the library (a function of amplitude returning a frequency offset in Hz)."""
    parameters = dict(REFERENCE_JOINT)
    for effect in effects:
        parameters.update(EFFECTS[effect].instance)
    frequency, damping = model_backbone(parameters, amplitudes, REFERENCE_FREQUENCY_HZ, REFERENCE_DAMPING,
                                        amplitudes[-1])
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
                        duration_s: float = 4.0, pretrigger_s: float = 0.0, hits: int = 1,
                        second_mode: tuple[float, float] | None = None, shapes=((1.0,), (1.0,)),
                        drift: float = 0.0, drift_within_hit: float = 0.0, start_fractions=None
                        ) -> list[RingDown]:
    """Hammer hits on the reference joint's backbone with ``effects``, each a free decay from the largest
    amplitude of ``AMPLITUDES`` (or a fraction of it: ``start_fractions``) after ``pretrigger_s`` of rest (module
    docstring): displacement sensors with seeded noise. After a pre-trigger the decay starts from rest as an
    impulse leaves it (zero displacement); without one the record starts at the decay's largest displacement (the
    impact itself not recorded). The hits follow one another without gap, hit k's time running from k ``duration_s``.

    Content outside the backbone, for the signal checks (``experiment.signal_checks``):
    second_mode: (frequency ratio, amplitude ratio) of a linear mode beside the target, with the target's
    low-amplitude damping, excited by the same impulse (its initial amplitude the ratio times the target's).
    shapes: the target's and the second mode's shapes at the sensors (one entry per sensor; the default: one
    sensor that sees both alike; orthogonal shapes, e.g. (1, 1) and (1, -1), are what a modal filter projects the
    second mode out of).
    drift: relative change of the target's frequency over all the hits, linear in time (a temperature drift):
    omega(a, t) = omega(a) (1 + drift t / (hits duration_s)).
    drift_within_hit: relative change of the target's frequency over each hit's decay, linear in the time s since
    that hit's impact and back at its start in the next hit (a joint that loosens while it rings and settles
    between hits): omega(a, s) = omega(a) (1 + drift_within_hit s / (duration_s - pretrigger_s)).
    start_fractions: (hits,) each hit's initial amplitude as a fraction of the largest of ``AMPLITUDES`` (hits of
    different strength; default: all 1). The same amplitude is then reached at different times since the impact,
    which is what tells a drift within each hit from the backbone.
    """
    grid = np.geomspace(AMPLITUDES[0] / 20, AMPLITUDES[-1], 400)  # the effects scale with AMPLITUDES[-1]
    frequency, damping = true_backbone(effects, amplitudes=grid)
    omega, log_grid = 2 * np.pi * frequency, np.log(grid)
    total_s, decay_s = hits * duration_s, duration_s - pretrigger_s
    starts = AMPLITUDES[-1] * (np.ones(hits) if start_fractions is None else np.asarray(start_fractions, float))
    rng = np.random.default_rng(seed)
    records = []
    for number in range(hits):
        start = number * duration_s
        time = start + np.arange(0.0, duration_s, 1.0 / sample_rate_hz)
        moving = time >= start + pretrigger_s

        def slow_flow(t, state):  # state: log amplitude, phase
            omega_now = (np.interp(state[0], log_grid, omega) * (1.0 + drift * t / total_s)
                         * (1.0 + drift_within_hit * (t - start - pretrigger_s) / decay_s))
            return [-np.interp(state[0], log_grid, damping) * omega_now, omega_now]

        # tight: the phase after ~700 periods must be right to far below the sensor noise's 1e-3 of the amplitude
        flow = solve_ivp(slow_flow, (time[moving][0], time[-1]), [np.log(starts[number]), 0.0],
                         t_eval=time[moving], rtol=1e-10, atol=1e-12, method="DOP853")
        modal = np.zeros((2, time.size))
        onset = -np.pi / 2 if pretrigger_s > 0 else 0.0  # from rest, an impulse; else the top of the decay
        modal[0, moving] = np.exp(flow.y[0]) * np.cos(flow.y[1] + onset)
        if second_mode is not None:
            ratio, amplitude_ratio = second_mode
            omega_2, elapsed = ratio * omega[0], time[moving] - time[moving][0]
            modal[1, moving] = (amplitude_ratio * AMPLITUDES[-1] * np.exp(-damping[0] * omega_2 * elapsed)
                                * np.cos(omega_2 * elapsed + onset))
        displacement = np.column_stack(shapes) @ modal
        noise = AMPLITUDES[-1] * 10 ** (-noise_db / 20) * rng.standard_normal(displacement.shape)
        names = ("sensor",) if len(shapes[0]) == 1 else tuple(f"sensor {k + 1}" for k in range(len(shapes[0])))
        records.append(RingDown(time, displacement + noise, names, "displacement",
                                f"virtual ring-down for the discrepancy loop (seed {seed})", str(number + 1)))
    return records


def write_undeclared_ringdown(destination: Path, effects=(), seed: int = 0, **options) -> None:
    """Write :func:`undeclared_ringdown` as a ring-down CSV (the effects appear nowhere in the file)."""
    ring_downs = undeclared_ringdown(effects, seed, **options)
    write_ringdown_csv(ring_downs, Path(destination), comment=f"VIRTUAL data: {ring_downs[0].source}",
                       provenance="virtual")
