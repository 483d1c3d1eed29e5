"""False-alarm rate and detection limit of the drift checks (``experiment.signal_checks.drift_findings``) on
virtual hammer hits of the project's generator (``discrepancy.virtual_data.undeclared_ringdown``): 7 hits of
1.7 s (0.05 s pre-trigger) at 4096 Hz, starting at the generator's top amplitude down to half of it (geometric),
one sensor with white noise 60 dB below the top amplitude (``--noise-db``).

Only what the drift check reads is computed: each hit's noiseless decay once per drift (the generator with no
noise), the generator's white noise added per seed, FreeVib on each hit's band-passed signal (no twins, no cycle
estimator), the backbone's grid. False alarms: clean hits, with time stamps (the hits one after another) and
without (each hit's clock from 0: the order of the hits), the share of files with a drift finding at the stated
``FALSE_ALARM`` and at 1e-2 and 5e-2 (which should come out near those values if the standard errors are
honest). Detection: a frequency drift within each hit of a relative size over a hit's decay, the share of files
where a drift within each hit is found with the right sign, and the median relative error of its rate.
Run: ``python -m benchmarks.drift [--files 200] [--detection-files 50]`` (about 0.3 s a file on an idle core).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from discrepancy.virtual_data import AMPLITUDES, undeclared_ringdown
from experiment.backbone import ModeRecord, RingDownBackbones, amplitude_grid, average_backbones, mode_signals
from experiment.hilbert import freevib
from experiment.signal_checks import FALSE_ALARM, drift_findings

MODE_HZ = 169.0
BAND = (0.7 * MODE_HZ, 1.3 * MODE_HZ)
HITS = {"hits": 7, "duration_s": 1.7, "pretrigger_s": 0.05, "start_fractions": 0.5 ** np.linspace(0.0, 1.0, 7)}
NOISE_DB = 60.0
DECAY_S = HITS["duration_s"] - HITS["pretrigger_s"]


def noisy(clean, seed: int, stamped: bool, noise_db: float = NOISE_DB):
    """The noiseless hits with the generator's white noise (``noise_db`` below the top amplitude) from ``seed``;
    without stamps each hit's clock starts at 0."""
    rng = np.random.default_rng(seed)
    hits = [replace(hit, signals=hit.signals + AMPLITUDES[-1] * 10 ** (-noise_db / 20)
                    * rng.standard_normal(hit.signals.shape)) for hit in clean]
    return hits if stamped else [replace(hit, time=hit.time - hit.time[0]) for hit in hits]


def drift_backbone(hits) -> RingDownBackbones:
    """FreeVib on each hit's band-passed signal and the backbone's amplitude grid: what the drift check reads."""
    records = []
    for hit in hits:
        (label, signal), = mode_signals(hit, BAND, None, 0, False)[0]
        estimate = freevib(hit.time, signal, MODE_HZ, quantity=hit.quantity)
        records.append(ModeRecord(label, estimate, estimate))
    grid = amplitude_grid([record.hilbert for record in records], 25)
    backbone = average_backbones([record.hilbert for record in records], grid)
    return RingDownBackbones("benchmark", MODE_HZ, "m", {"sensor": 1.0}, records, backbone, backbone)


def false_alarms(files: int, stamped: bool, noise_db: float = NOISE_DB, levels=(FALSE_ALARM, 1e-2, 5e-2)) -> dict:
    """Share of clean files with a drift finding at each false-alarm level, and the findings' clocks."""
    clean = undeclared_ringdown(noise_db=np.inf, **HITS)
    counts, clocks = dict.fromkeys(levels, 0), []
    for seed in range(files):
        hits = noisy(clean, seed, stamped, noise_db)
        measured = drift_backbone(hits)
        for level in levels:
            found = drift_findings(hits, measured, level)
            counts[level] += bool(found)
            clocks += [entry["evidence"]["clock"] for entry in found] if level == levels[-1] else []
    return {"rates": {level: count / files for level, count in counts.items()}, "clocks": sorted(set(clocks))}


def detection(drift: float, files: int, stamped: bool, noise_db: float = NOISE_DB) -> tuple[float, float]:
    """Share of files where a frequency drift within each hit of ``drift`` (relative, over a hit's decay) is
    found with its sign, and the median |relative error| of the rate found."""
    clean = undeclared_ringdown(noise_db=np.inf, drift_within_hit=drift, **HITS)
    hits_found, errors = 0, []
    for seed in range(files):
        hits = noisy(clean, 10_000 + seed, stamped, noise_db)
        for entry in drift_findings(hits, drift_backbone(hits)):
            evidence = entry["evidence"]
            if (evidence["clock"] == "time since each hit's impact" and evidence["quantity"] == "natural_frequency_hz"
                    and np.sign(evidence["relative_rate_per_s"]) == np.sign(drift)):
                hits_found += 1
                errors.append(abs(evidence["relative_rate_per_s"] * DECAY_S / drift - 1))
    return hits_found / files, float(np.median(errors)) if errors else np.nan


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=200,
                        help="clean files with and again without time stamps, for the false-alarm rate (0: none)")
    parser.add_argument("--detection-files", type=int, default=50, help="files per drift size for the detection (0: none)")
    parser.add_argument("--drifts", type=float, nargs="+", default=[2e-4, 4e-4, 6e-4, 7e-4, 8e-4, 1e-3],
                        help="relative frequency drifts within each hit, over a hit's decay")
    parser.add_argument("--noise-db", type=float, default=NOISE_DB, help="sensor noise below the top amplitude, dB")
    arguments = parser.parse_args(argv)
    for stamped in (False, True) if arguments.files else ():
        start = time.perf_counter()
        result = false_alarms(arguments.files, stamped, arguments.noise_db)
        shares = ", ".join(f"{rate:.4f} at {level:g}" for level, rate in result["rates"].items())
        print(f"clean, {'time stamps' if stamped else 'no time stamps'}, {arguments.noise_db:g} dB: {arguments.files} "
              f"files, share with a drift finding {shares}; clocks found at the last level: {result['clocks']} "
              f"({time.perf_counter() - start:.0f} s)", flush=True)
    for drift in arguments.drifts if arguments.detection_files else ():
        for sign in (-1, 1):
            start = time.perf_counter()
            share, error = detection(sign * drift, arguments.detection_files, False, arguments.noise_db)
            print(f"drift within each hit {sign * drift:+.1e} over the decay: found with its sign in {share:.2f} of "
                  f"{arguments.detection_files} files, median |rate error| {error:.3f} "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
