"""False-alarm rate and detection limits of the second-mode check (``experiment.signal_checks.second_mode``) on
virtual hammer hits of two generators, the check run alone on the hits in memory (no FreeVib, no files):

- project: the project's generator (``discrepancy.virtual_data.undeclared_ringdown``), displacement at 4096 Hz,
  7 hits of ``PROJECT_DURATION_S`` (0.05 s pre-trigger) from the generator's top amplitude, white noise 60 dB below
  it on each of 10 sensors that see the target in the shape ``TARGET_SHAPE`` (a free-free beam's first bending at
  the BRB's sensors) and a second mode (ratio times the reference's low-amplitude frequency, the target's
  low-amplitude damping) in the orthogonal ``SECOND_SHAPE``;
- challenge-like: :func:`challenge_like_hits`, hits of a one-mode backbone in the layout of the ring-down challenge
  set (``../shared/data/ringdown-challenge/README.md``), written here from its description: the envelope equations
  dA/dt = -zeta(A) omega(A) A, dpsi/dt = omega(A) sqrt(1 - zeta^2) (DOP853, rtol 1e-10) on a backbone read from a
  CSV like ``reference_backbone.csv`` (omega and zeta by PCHIP in ln q, straight in ln q beyond the table), 10
  accelerometers in ``TARGET_SHAPE`` scaled to the table's sensor amplitude, 7 hits from 2 q_top down to q_top
  (geometric), 6.4 kHz, 0.05 s pre-trigger, 1.65 s of decay, white noise of 0.35 % of the largest sample on every
  channel, quantised to 1e-3; a second mode whose displacement envelope is a share of the target's (the same decay)
  at a ratio of the backbone's lowest-amplitude frequency, in ``SECOND_SHAPE``.

Each generator's noiseless hits are made once per content and the noise added per seed. False alarms: the share
of clean files with a finding at the stated ``FALSE_ALARM`` and at 1e-2 and 5e-2 (which should come out near those
values if the stated null distribution holds). Detection limit: at 2 %, 3 % and 5 % separation, the smallest
amplitude share of a grid found in 90 % of the files or more, with the median error of the frequency and share.
Run: ``python -m benchmarks.second_mode [--files 200] [--detection-files 20] [--backbone CSV]``.
"""

from __future__ import annotations

import argparse
import csv
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import PchipInterpolator

from benchmarks import MEASURED_DATA
from discrepancy.virtual_data import AMPLITUDES, REFERENCE_FREQUENCY_HZ, undeclared_ringdown
from experiment.ringdown import RingDown
from experiment.signal_checks import FALSE_ALARM, hit_residuals, second_mode

SENSORS_X = np.array([-0.330, -0.271, -0.211, -0.151, -0.091, 0.091, 0.151, 0.211, 0.271, 0.330])  # m
BEAM_LENGTH = 0.7112  # m, the BRB's overall length
CHALLENGE_BACKBONE = MEASURED_DATA / "ringdown-challenge" / "reference_backbone.csv"
PROJECT_DURATION_S = 2.0  # s per hit: the decay reaches the noise within it
LEVELS = (FALSE_ALARM, 1e-2, 5e-2)
SEPARATIONS = (0.02, 0.03, 0.05)
SHARES = (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2)


def free_free_first_bending(x: np.ndarray, length: float = BEAM_LENGTH) -> np.ndarray:
    """First bending mode of a free-free Euler-Bernoulli beam (beta L = 4.7300, sigma = 0.9825) at positions x (n,)
    m from the beam's middle, 1 at the ends."""
    beta, sigma = 4.730041 / length, 0.982502
    xi = beta * (np.asarray(x) + length / 2)
    return (np.cosh(xi) + np.cos(xi) - sigma * (np.sinh(xi) + np.sin(xi))) / 2


TARGET_SHAPE = free_free_first_bending(SENSORS_X) / np.max(np.abs(free_free_first_bending(SENSORS_X)))
SECOND_SHAPE = SENSORS_X / np.linalg.norm(SENSORS_X) * np.linalg.norm(TARGET_SHAPE)  # antisymmetric: orthogonal


def read_backbone_table(path: Path):
    """(q (n,) m kg^0.5, sensor amplitude over q at the sensor that moves most, omega (n,) rad/s, zeta (n,)) from
    a CSV like the challenge's ``reference_backbone.csv``: comment lines, a header, then columns modal amplitude,
    sensor amplitude, frequency (Hz), damping ratio."""
    with open(path) as handle:
        rows = [row for row in csv.reader(line for line in handle if not line.startswith("#"))][1:]
    table = np.array([[float(value) for value in row[:4]] for row in rows])
    return table[:, 0], float(np.median(table[:, 1] / table[:, 0])), 2 * np.pi * table[:, 2], table[:, 3]


def log_amplitude_law(q: np.ndarray, values: np.ndarray):
    """values (n,) against ln q: PCHIP inside the table, straight lines (the end slopes) outside it."""
    log_q = np.log(q)
    inside = PchipInterpolator(log_q, values, extrapolate=False)
    slopes = (values[1] - values[0]) / (log_q[1] - log_q[0]), (values[-1] - values[-2]) / (log_q[-1] - log_q[-2])

    def law(log_amplitude):
        return float(np.where(log_amplitude < log_q[0], values[0] + slopes[0] * (log_amplitude - log_q[0]),
                     np.where(log_amplitude > log_q[-1], values[-1] + slopes[1] * (log_amplitude - log_q[-1]),
                              inside(np.clip(log_amplitude, log_q[0], log_q[-1])))))
    return law


def challenge_like_clean(backbone, second=None, hits: int = 7, decay_s: float = 1.65, pretrigger_s: float = 0.05,
                         sample_rate: float = 6400.0, laws=None, drift: float = 0.0) -> list[RingDown]:
    """Noiseless accelerations (m/s^2) of the challenge-like hits (module docstring). backbone: the tuple of
    :func:`read_backbone_table`; second: (ratio to the lowest-amplitude frequency, share of the target's
    envelope) or None; laws: (omega (rad/s), zeta) as functions of ln q in place of the table's
    (:func:`log_amplitude_law`), e.g. with effects outside the joint (``benchmarks.held_out``), or None; drift:
    the frequency's relative fall within each hit over ``decay_s``, omega(A) (1 - drift t / decay_s) with t the
    time since the hit (the challenge README's P7 kind; negative: a rise)."""
    q, sensor_over_q, omega, zeta = backbone
    omega_of, zeta_of = laws or (log_amplitude_law(q, omega), log_amplitude_law(q, zeta))
    time = np.arange(int(round((pretrigger_s + decay_s) * sample_rate)) + 1) / sample_rate
    moving = time >= pretrigger_s
    shape = sensor_over_q * TARGET_SHAPE
    records = []

    def drifted(t):
        return 1.0 - drift * (t - pretrigger_s) / decay_s

    for number, start in enumerate(2 * q[-1] * 0.5 ** (np.arange(hits) / max(hits - 1, 1))):
        def envelope(t, state):  # state: ln A, psi
            omega_now, zeta_now = omega_of(state[0]) * drifted(t), zeta_of(state[0])
            return [-zeta_now * omega_now, omega_now * np.sqrt(1 - zeta_now ** 2)]

        flow = solve_ivp(envelope, (time[moving][0], time[-1]), [np.log(start), 0.0], t_eval=time[moving],
                         method="DOP853", rtol=1e-10, atol=1e-12)
        acceleration = (np.exp(flow.y[0]) * (np.array([omega_of(value) for value in flow.y[0]])
                                             * drifted(time[moving])) ** 2)
        signals = np.zeros((shape.size, time.size))
        signals[:, moving] = np.outer(shape, acceleration * np.sin(flow.y[1]))  # from rest: an impulse
        if second is not None:
            ratio, share = second
            omega_2 = ratio * omega[0]  # its displacement envelope: share times the target's
            signals[:, moving] += np.outer(sensor_over_q * SECOND_SHAPE, share * np.exp(flow.y[0]) * omega_2 ** 2
                                           * np.sin(omega_2 * (time[moving] - time[moving][0])))
        records.append(RingDown(time, signals, tuple(f"acc{k + 1}" for k in range(shape.size)), "acceleration",
                                "challenge-like virtual hits", f"hit {number + 1}"))
    return records


def challenge_like_hits(clean: list[RingDown], seed: int, noise_share: float = 3.5e-3, resolution: float = 1e-3
                        ) -> list[RingDown]:
    """The noiseless hits with white noise of ``noise_share`` of the largest sample on every channel (seeded),
    quantised to ``resolution`` (signal unit)."""
    rng = np.random.default_rng(seed)
    level = noise_share * max(np.max(np.abs(hit.signals)) for hit in clean)
    return [replace(hit, signals=np.round((hit.signals + level * rng.standard_normal(hit.signals.shape)) / resolution)
                    * resolution) for hit in clean]


def project_clean(second=None, hits: int = 7, duration_s: float = PROJECT_DURATION_S) -> list[RingDown]:
    """The project generator's noiseless hits (``duration_s`` s each) on the 10 sensors (module docstring);
    second: (frequency ratio, amplitude ratio) or None."""
    return undeclared_ringdown(noise_db=np.inf, hits=hits, duration_s=duration_s, pretrigger_s=0.05,
                               second_mode=second, shapes=(tuple(TARGET_SHAPE), tuple(SECOND_SHAPE)))


def project_hits(clean: list[RingDown], seed: int, noise_db: float = 60.0) -> list[RingDown]:
    """The noiseless hits with the generator's white noise, ``noise_db`` below its top amplitude, from ``seed``."""
    rng = np.random.default_rng(seed)
    return [replace(hit, signals=hit.signals + AMPLITUDES[-1] * 10 ** (-noise_db / 20)
                    * rng.standard_normal(hit.signals.shape)) for hit in clean]


GENERATORS = {
    "project": {"mode_hz": 169.0, "clean": lambda backbone, second: project_clean(second), "noisy": project_hits,
                "stuck_hz": REFERENCE_FREQUENCY_HZ},
    "challenge-like": {"mode_hz": 170.0, "clean": lambda backbone, second: challenge_like_clean(backbone, second),
                       "noisy": challenge_like_hits, "stuck_hz": None},
}


def check(hits: list[RingDown], mode_hz: float, levels=LEVELS) -> dict:
    """The second-mode check at each false-alarm level: {level: evidence or None}."""
    band = (0.7 * mode_hz, 1.3 * mode_hz)
    removed, several = hit_residuals(hits, mode_hz, band)
    return {level: second_mode(removed, mode_hz, band, hits[0].sample_rate, level, several) for level in levels}


def false_alarms(generator: str, backbone, files: int) -> dict:
    """Share of clean files with a finding at each level of ``LEVELS``, and the seconds per file."""
    settings = GENERATORS[generator]
    clean = settings["clean"](backbone, None)
    counts, start = dict.fromkeys(LEVELS, 0), time.perf_counter()
    for seed in range(files):
        for level, evidence in check(settings["noisy"](clean, seed), settings["mode_hz"]).items():
            counts[level] += evidence is not None
    return {"files": files, "rates": {level: count / files for level, count in counts.items()},
            "seconds_per_file": (time.perf_counter() - start) / files}


def detection_limit(generator: str, backbone, separation: float, files: int, seed_offset: int = 10_000) -> dict:
    """The smallest share of ``SHARES`` found (at ``FALSE_ALARM``, within 0.5 % of its frequency) in 90 % of the
    files or more at ``separation`` above the lowest-amplitude frequency, the shares tried in rising order up to
    it, with each one's detection rate and median relative errors of frequency and share."""
    settings = GENERATORS[generator]
    stuck_hz = settings["stuck_hz"] or backbone[2][0] / (2 * np.pi)
    rows = {}
    for share in SHARES:
        clean = settings["clean"](backbone, (1 + separation, share))
        found, frequency_error, share_error = 0, [], []
        for seed in range(seed_offset, seed_offset + files):
            evidence = check(settings["noisy"](clean, seed), settings["mode_hz"], (FALSE_ALARM,))[FALSE_ALARM]
            if evidence is not None and abs(evidence["frequency_hz"] / ((1 + separation) * stuck_hz) - 1) < 5e-3:
                found += 1
                frequency_error.append(evidence["frequency_hz"] / ((1 + separation) * stuck_hz) - 1)
                share_error.append(evidence["relative_amplitude"] / share - 1)
        rows[share] = {"rate": found / files,
                       "frequency_error": float(np.median(frequency_error)) if frequency_error else np.nan,
                       "share_error": float(np.median(share_error)) if share_error else np.nan}
        if rows[share]["rate"] >= 0.9:
            return {"separation": separation, "limit": share, "rows": rows}
    return {"separation": separation, "limit": None, "rows": rows}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=200, help="clean files per generator")
    parser.add_argument("--detection-files", type=int, default=20, help="files per share and separation")
    parser.add_argument("--backbone", type=Path, default=CHALLENGE_BACKBONE, help="backbone CSV of the challenge-"
                        "like generator (the challenge's reference_backbone.csv by default)")
    parser.add_argument("--generators", nargs="+", default=list(GENERATORS), choices=list(GENERATORS))
    arguments = parser.parse_args(argv)
    backbone = read_backbone_table(arguments.backbone) if "challenge-like" in arguments.generators else None
    for generator in arguments.generators:
        if arguments.files:
            result = false_alarms(generator, backbone, arguments.files)
            rates = ", ".join(f"{rate:.3f} at {level:g}" for level, rate in result["rates"].items())
            print(f"{generator}: false alarms in {result['files']} clean files: {rates} "
                  f"({result['seconds_per_file']:.2f} s per file)", flush=True)
        for separation in SEPARATIONS if arguments.detection_files else ():
            result = detection_limit(generator, backbone, separation, arguments.detection_files)
            rows = "; ".join(f"{share:g}: {row['rate']:.2f} (f {100 * row['frequency_error']:+.3f} %, share "
                             f"{100 * row['share_error']:+.0f} %)" for share, row in result["rows"].items())
            print(f"{generator}: {100 * separation:g} % above: found in >= 90 % of {arguments.detection_files} files "
                  f"from share {result['limit']}; {rows}", flush=True)


if __name__ == "__main__":
    main()
