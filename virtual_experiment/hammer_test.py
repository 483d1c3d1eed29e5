"""Virtual experiments of the three Brake-Reuss beams: one reference joint, hammer ring-downs, a measured backbone.

The paper's Fig. 3 backbones of the BRB, LBRB and SBRB (seed paper section 3: first out-of-plane bending mode,
Hilbert (FreeVib) estimates averaged over seven hammer hits) are not public. A virtual experiment stands in for
each (docs/design.md section 7): the same reference joint in all three beams, the beam's linear damping from the paper's
Table 1, seven hammer hits simulated on the project's superelement, ten accelerometers with sensor noise, and
the records processed exactly like a measurement (:func:`experiment.backbone.ringdown_backbone`: modal filter with
the low-level mode shapes, band-pass, FreeVib, averaging over the hits). Its backbone is labelled ``virtual``.

Hammer test (:class:`HammerTest`). Seven half-sine hits of 3 ms (a soft tip: first spectral zero at 500 Hz) at the
accelerometer at the beam's free end (where the first bending mode moves most), along its axis. FreeVib discards
the first 12 periods, in which a hard hit's damping (1-3e-2) takes the amplitude down by a factor 2-3, and a
record of 70 periods keeps a factor 2-4 of decay; one impulse level cannot cover the decade from near-linear to
the 2 % drop in a record the demo can afford, so the hits are spread as an experimenter spreads them: nominal
impulses log-spaced down by a factor 20 from the one that gives the tracked mode a modal amplitude of 1.2e-3
m kg^0.5 (BRB 1.6 N s, peak force 840 N; LBRB 0.96 N s), each scattered by 5 % (seeded), the
ranges of neighbouring hits overlapping (every grid amplitude has data). The sensors record displacement (ring_down's output). Sensor noise: Gaussian, standard deviation 1e-3 of the
tracked mode's largest displacement at any sensor during the hit (60 dB below the peak, a typical usable dynamic range of a hammer
ring-down once range setting, cables and mounting are counted), independent per channel and sample.

Time step. The transient (:func:`nonlinear.transient.ring_down`) integrates with Newmark's average acceleration
rule, whose period error (omega dt)^2 / 12 is the virtual experiment's only systematic frequency error: 50 samples
per period give 0.13 % (0.22 Hz on the BRB), measured so against QSMA. Its Newton loop updates 2,508 sliders per
joint element every iteration, 1.7-3 ms per step: 6-11 s per hit, about a minute per beam in one process. The
hits run side by side on one worker process per core (``pipeline.runners.process_pool``), with the same bits as in
one process.
"""

from __future__ import annotations

import csv
import platform
import time as clock
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import NamedTuple

import numpy as np

from experiment.backbone import ModeBackbone, RingDownBackbones
from experiment.ringdown_analysis import analyse_ringdown
from experiment.backbone_files import ASB_MODAL_AMPLITUDE_UNIT, write_backbone
from experiment.ringdown import RingDown
from experiment.ringdown_files import write_ringdown_mat
from geometry.parameters import BEAM_NAMES
from nonlinear.condensation import JointSpace
from nonlinear.joint import parameter_names
from nonlinear.transient import Hammer, ring_down, sensor_modes
from pipeline.cache import package_versions
from pipeline.files import atomic_path, sha256_file, write_json
from pipeline.published import TABLE1, TABLE3, LowAmplitude
from pipeline.runners import SERIAL, process_pool
from virtual_experiment.reference_joint import MODEL, beam_space, outside_limits, reference_joint, stuck_frequency_hz

@dataclass(frozen=True)
class HammerTest:
    """How a beam is hit and recorded (module docstring).

    n_hits: hammer hits. sensor: row of the superelement's sensors hit (along its axis), 0-based.
    peak_modal_amplitude: modal amplitude q (m kg^0.5) the hardest hit gives the tracked mode, the same on every
    beam: its impulse is q omega / |phi(struck point)| (an ideal impulse I gives q' = I phi, q = q' / omega).
    impulse_range: hardest over softest nominal impulse (the nominal impulses are log-spaced between them). impulse_scatter: relative standard deviation of each hit's
    impulse about its nominal one. contact_time: s. periods: record length in periods of the Table 1 frequency.
    samples_per_period: integrator steps (and samples) per period. noise: standard deviation of the sensor noise
    relative to the largest displacement of the tracked mode at any sensor during the hit. seed: of the numpy
    Generator that draws the impulses, then the noise.
    """

    n_hits: int = 7
    sensor: int = 0
    peak_modal_amplitude: float = 1.2e-3
    impulse_range: float = 20.0
    impulse_scatter: float = 0.05
    contact_time: float = 3e-3
    periods: float = 70.0
    samples_per_period: int = 50
    noise: float = 1e-3
    seed: int = 20190617

    def time_step(self, frequency_hz: float) -> float:
        """Integrator step and sampling interval (s) for a mode of ``frequency_hz``."""
        return 1.0 / (self.samples_per_period * frequency_hz)

    def duration(self, frequency_hz: float) -> float:
        """Record length (s) for a mode of ``frequency_hz``."""
        return self.periods / frequency_hz


def hit_impulses(test: HammerTest, hardest_impulse: float, rng: np.random.Generator) -> np.ndarray:
    """Impulses (n_hits,) N s, softest first: nominal ones log-spaced from hardest / range to ``hardest_impulse``
    (N s), each times 1 + scatter x a standard normal draw (clipped at +-3)."""
    nominal = hardest_impulse * np.geomspace(1.0 / test.impulse_range, 1.0, test.n_hits)
    return nominal * (1.0 + test.impulse_scatter * np.clip(rng.standard_normal(test.n_hits), -3.0, 3.0))


def with_sensor_noise(hit: RingDown, level: float, rng: np.random.Generator) -> RingDown:
    """The hit with independent Gaussian noise of standard deviation ``level`` (its unit) on every channel and
    sample."""
    return replace(hit, signals=hit.signals + level * rng.standard_normal(hit.signals.shape))


def modal_test_shapes(space: JointSpace, design, n_modes: int = 5, visibility: float = 1e-2, model: str = MODEL):
    """Mode shapes at the sensors (n_sensors, n_modes) as a low-level modal test identifies them: of the stuck
    modes the sensors see (norm of the shape at the sensors at least ``visibility`` times the tracked mode's), the
    ``n_modes`` nearest the tracked one in frequency, the tracked one first; in m per unit modal amplitude q
    (m kg^0.5), so that modal filtering gives q. Also returns the tracked frequency, Hz.

    The beams' sensors read u_z on the centre line, blind to the in-plane and torsion modes between the bending
    ones (their shapes there are 1e-4 of the bending modes'); a modal filter including them would divide the
    sensor noise by those near-zero singular values. Fewer modes than sensors make the filter a least-squares fit.
    """
    frequencies, shapes, target = sensor_modes(space, model, design)
    seen = np.linalg.norm(shapes, axis=0) >= visibility * np.linalg.norm(shapes[:, target])
    candidates = np.flatnonzero(seen)
    nearest = candidates[np.argsort(np.abs(frequencies[candidates] - frequencies[target]), kind="stable")[:n_modes]]
    return shapes[:, nearest], float(frequencies[target]) / (2.0 * np.pi)


class HammerHits(NamedTuple):
    """The records of a hammer test: hits (noisy sensor displacements, :class:`~experiment.ringdown.RingDown`),
    impulses (n_hits,) N s, noise_levels (n_hits,) m, runtime_s (n_hits,) seconds of simulation per hit,
    unconverged_steps (n_hits,) Newton steps that missed the tolerance (0 for a trustworthy run)."""

    hits: list[RingDown]
    impulses: np.ndarray
    noise_levels: np.ndarray
    runtime_s: np.ndarray
    unconverged_steps: np.ndarray


def simulated_hit(space: JointSpace, model: str, design, linear_damping: float, frequency_hz: float,
                  test: HammerTest, impulse: float):
    """One noise-free hit of ``test`` with ``impulse`` (N s): the transient ring-down
    (:func:`nonlinear.transient.ring_down`) and its runtime (s)."""
    start = clock.perf_counter()
    decay = ring_down(space, model, design, test.duration(frequency_hz), test.time_step(frequency_hz),
                      hammer=Hammer(space.superelement.sensors[test.sensor], float(impulse), test.contact_time),
                      linear_damping=linear_damping)
    return decay, clock.perf_counter() - start


def hammer_hits(space: JointSpace, beam: str, design, linear_damping: float, frequency_hz: float,
                test: HammerTest = HammerTest(), model: str = MODEL, runner=SERIAL) -> HammerHits:
    """Simulate the hits of ``test`` on the joint ``design`` in the beam of ``space``.

    Each hit is a transient ring-down (:func:`simulated_hit`) from rest under a half-sine hammer pulse at the
    test's sensor, linear damping zeta_0 = ``linear_damping`` on every stuck mode, time step and length from the
    beam's measured ``frequency_hz`` (``test``); the sensors' displacements get independent Gaussian noise of
    ``test.noise`` times the largest displacement of the tracked mode at any sensor. The seeded Generator draws
    the impulses first, then the noise hit by hit. ``runner`` (``pipeline.runners``; a
    ``process_pool`` simulates the hits side by side) gives the same bits as one process.
    """
    design = np.asarray(design, dtype=float)
    rng = np.random.default_rng(test.seed)
    frequencies, shapes, target = sensor_modes(space, model, design)
    hardest = test.peak_modal_amplitude * frequencies[target] / abs(shapes[test.sensor, target])
    impulses = hit_impulses(test, hardest, rng)
    largest_sensor_shape = np.max(np.abs(shapes[:, target]))
    simulate = partial(simulated_hit, space, model, design, linear_damping, frequency_hz, test)
    hits, levels, runtime, unconverged = [], [], [], []
    simulated = runner.map(simulate, [(impulse,) for impulse in impulses])
    for number, (decay, seconds) in enumerate(simulated, start=1):
        runtime.append(seconds)
        unconverged.append(decay.unconverged_steps)
        levels.append(test.noise * np.max(np.abs(decay.modal_amplitude)) * largest_sensor_shape)
        record = replace(decay.sensors, source=f"virtual experiment {beam}", hit=f"hit {number}")
        hits.append(with_sensor_noise(record, levels[-1], rng))
    return HammerHits(hits, impulses, np.array(levels), np.array(runtime), np.array(unconverged))


@dataclass(frozen=True)
class VirtualExperiment:
    """One beam's virtual experiment.

    beam: name. backbone: the Hilbert backbone labelled virtual (amplitude: modal amplitude q, m kg^0.5).
    measured: both estimators as :func:`experiment.backbone.ringdown_backbone` returns them. records: the hits.
    stuck_frequency_hz: the design's stuck frequency in this beam. configuration: everything that generated it
    (JSON-ready).
    """

    beam: str
    backbone: ModeBackbone
    measured: RingDownBackbones = field(repr=False)
    records: HammerHits = field(repr=False)
    stuck_frequency_hz: float
    configuration: dict = field(repr=False)


def analysed_hits(space: JointSpace, beam: str, design, records: HammerHits, model: str = MODEL
                  ) -> tuple[ModeBackbone, RingDownBackbones]:
    """The hits processed as a measurement (:func:`experiment.ringdown_analysis.analyse_ringdown`, labelled
    virtual) with the low-level mode shapes of :func:`modal_test_shapes` (modal filter, band-pass 0.7-1.3 f,
    FreeVib, mean over hits); the signal checks are not run (the simulated hits start at the impact and pass
    through no instrument)."""
    shapes, mode_frequency_hz = modal_test_shapes(space, design, model=model)
    return analyse_ringdown(records.hits, mode_frequency_hz, beam, "virtual", check_signals=False,
                            mode_shapes=shapes, mode_index=0)


def virtual_experiment(space: JointSpace, beam: str, design, linear_damping: float, frequency_hz: float,
                       test: HammerTest = HammerTest(), model: str = MODEL,
                       runner=SERIAL) -> VirtualExperiment:
    """Hammer test of the joint ``design`` in the beam of ``space`` (:func:`hammer_hits`), processed as a
    measurement (:func:`analysed_hits`), labelled virtual; the amplitude is the modal amplitude q (m kg^0.5)
    since the filter's shapes are mass-normalised.

    linear_damping: zeta_0 of the beam's other mechanisms (paper Table 1). frequency_hz: the beam's measured
    (Table 1) frequency, which sets the time step and the record length. runner: see :func:`hammer_hits`.
    """
    design = np.asarray(design, dtype=float)
    superelement = space.superelement
    records = hammer_hits(space, beam, design, linear_damping, frequency_hz, test, model, runner)
    labelled, measured = analysed_hits(space, beam, design, records, model)
    stuck = stuck_frequency_hz(space, design, model)
    names = parameter_names(model, int(np.max(superelement.patch_groups)) + 1)
    configuration = {
        "provenance": "virtual", "beam": beam, "model": model,
        "parameter_names": names, "design": design.tolist(),
        "stuck_frequency_hz": stuck, "linear_damping": linear_damping, "table1_frequency_hz": frequency_hz,
        "hammer": {"sensor_row": test.sensor, "direction": "the sensor's measuring axis (u_z)",
                   "pulse": "half-sine", "contact_time_s": test.contact_time,
                   "peak_modal_amplitude": test.peak_modal_amplitude, "impulse_range": test.impulse_range,
                   "impulse_scatter": test.impulse_scatter, "impulses_Ns": records.impulses.tolist()},
        "sensors": {"count": len(superelement.sensors), "quantity": "displacement",
                    "noise": "Gaussian, independent per channel and sample, standard deviation relative to the "
                             "largest displacement of the tracked mode at any sensor during the hit",
                    "relative_noise": test.noise, "noise_levels_m": records.noise_levels.tolist()},
        "seed": test.seed, "time_step_s": test.time_step(frequency_hz), "duration_s": test.duration(frequency_hz),
        "samples_per_period": test.samples_per_period,
        "integrator": "Newmark average acceleration, period error (omega dt)^2/12 = "
                      f"{(2 * np.pi / test.samples_per_period) ** 2 / 12:.2e}",
        "processing": "experiment.backbone.ringdown_backbone: modal filter with the 5 stuck modes the sensors see "
                      "nearest the tracked one, band-pass 0.7-1.3 f, FreeVib (Hilbert), mean over hits",
        "runtime_s_per_hit": records.runtime_s.tolist(),
        "unconverged_steps": records.unconverged_steps.tolist(),
    }
    backbone = replace(labelled, backbone=labelled.backbone.with_data(), amplitude_unit=ASB_MODAL_AMPLITUDE_UNIT,
                       source=f"virtual experiment: {model} reference joint in {superelement.name}, "
                              f"{test.n_hits} simulated hammer hits (seed {test.seed})")
    return VirtualExperiment(beam, backbone, measured, records, stuck, configuration)


def versions() -> dict:
    """Versions recorded with a virtual experiment: Python and the numerical packages."""
    return {"python": platform.python_version(), **package_versions("numpy", "scipy", "numba")}


def experiment_record_path(folder: Path, beam: str) -> Path:
    """The record of a beam's virtual experiment in a measurements folder: its generating configuration,
    superelement, versions and runtimes (:func:`write_virtual_experiment`)."""
    return Path(folder) / f"{beam}_experiment.json"


def write_virtual_experiment(folder: Path, experiment: VirtualExperiment, rom_path: Path,
                             ring_downs: bool = True) -> dict[str, Path]:
    """Write ``<folder>/<beam>.csv`` (the backbone CSV of :mod:`experiment.backbone_files`, provenance virtual),
    ``<folder>/<beam>_experiment.json`` (the generating configuration, the superelement file and its SHA-256,
    versions, runtimes) and, with ``ring_downs``, ``<folder>/<beam>_ringdowns.mat`` (the noisy hits), each
    atomically; the JSON last. rom_path: the superelement file the experiment's joint space came from (its
    prestressed halves; recorded). Returns kind -> path."""
    folder = Path(folder)
    paths = {"backbone": folder / f"{experiment.beam}.csv",
             "configuration": experiment_record_path(folder, experiment.beam)}
    write_backbone(experiment.backbone, paths["backbone"])
    if ring_downs:
        paths["ring_downs"] = folder / f"{experiment.beam}_ringdowns.mat"
        write_ringdown_mat(experiment.records.hits, paths["ring_downs"], provenance="virtual")
    write_json(paths["configuration"], {
        **experiment.configuration,
        "superelement": {"file": str(rom_path), "sha256": sha256_file(rom_path),
                         "stiffness": "prestressed halves K_A + K_bolt (reduction.superelement.beam_superelement)"},
        "versions": versions(),
        "files": {kind: {"name": path.name, "sha256": sha256_file(path)} for kind, path in paths.items()
                  if kind != "configuration"},
    })
    return paths


def low_amplitude_table(experiments: dict[str, VirtualExperiment],
                        measurements: dict[str, LowAmplitude]) -> list[dict]:
    """Each beam's virtual low-amplitude frequency (the backbone's value at its lowest amplitude) against Table 1:
    rows {beam, virtual_hz, table1_hz, difference_percent}, in the order of ``experiments``."""
    rows = []
    for beam, experiment in experiments.items():
        virtual, measured = experiment.backbone.low_amplitude_frequency_hz, measurements[beam].frequency_hz
        rows.append({"beam": beam, "virtual_hz": virtual, "table1_hz": measured,
                     "difference_percent": 100.0 * (virtual / measured - 1.0)})
    return rows


def write_low_amplitude_table(rows: list[dict], destination: Path) -> None:
    """Write :func:`low_amplitude_table`'s rows as CSV (beam, virtual_hz, table1_hz, difference_percent), atomically."""
    with atomic_path(destination) as temporary, open(temporary, "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=["beam", "virtual_hz", "table1_hz", "difference_percent"])
        writer.writeheader()
        writer.writerows(rows)


def virtual_experiments(rom_folder: Path, out_folder: Path, table1: dict[str, LowAmplitude] = TABLE1,
                        table3: dict[str, tuple[float, float, bool]] = TABLE3, test: HammerTest = HammerTest(),
                        beams=BEAM_NAMES, ring_downs: bool = True) -> list[dict]:
    """The three beams' virtual experiments with one reference joint, written to ``out_folder``.

    rom_folder: holds ``<beam>.npz`` (the reduction stage's output). table1, table3: the paper's Tables 1 and 3
    (``pipeline.published``). The reference joint is tuned on the BRB to its Table 1 frequency and checked
    against Table 3's limits (ValueError naming the parameters otherwise); each
    beam is tested with ``test`` and its Table 1 linear damping, then written by :func:`write_virtual_experiment`;
    ``low_amplitude.csv`` compares the virtual low-amplitude frequencies with Table 1. Returns its rows. The hits
    run on one worker process per core (``pipeline.runners.process_pool``).
    """
    rom_folder, out_folder = Path(rom_folder), Path(out_folder)
    spaces = {beam: beam_space(rom_folder / f"{beam}.npz", table1[beam].frequency_hz)
              for beam in dict.fromkeys(("BRB", *beams))}
    design = reference_joint(spaces["BRB"], table1["BRB"].frequency_hz)
    names = parameter_names(MODEL, int(np.max(spaces["BRB"].superelement.patch_groups)) + 1)
    outside = outside_limits(design, names, table3)
    if outside:
        raise ValueError(f"reference joint outside paper Table 3's limits: {'; '.join(outside)}")
    experiments = {}
    with process_pool() as runner:
        for beam in beams:
            measurement = table1[beam]
            experiments[beam] = virtual_experiment(spaces[beam], beam, design, measurement.damping,
                                                   measurement.frequency_hz, test, runner=runner)
            write_virtual_experiment(out_folder, experiments[beam], rom_folder / f"{beam}.npz", ring_downs)
    rows = low_amplitude_table(experiments, table1)
    write_low_amplitude_table(rows, out_folder / "low_amplitude.csv")
    return rows
