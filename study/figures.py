"""The study's figures (matplotlib, Agg, written atomically): Pareto fronts in the error plane (paper Fig. 6)
and the responses of representative front designs against the measurement (paper Figs. 9-11)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nonlinear.qsma_vectorised import qsma_designs  # noqa: E402
from study.errors import structure_damping  # noqa: E402
from pipeline.files import atomic_path  # noqa: E402


def save(figure, destination: Path) -> None:
    with atomic_path(destination) as temporary:
        figure.savefig(temporary, dpi=110, format="png")
    plt.close(figure)


def plot_fronts(destination: Path, model: str, names, errors, n_designs: int, fronts, acceptance) -> None:
    """Each structure's sample in the error plane (log axes), its non-dominated front, NSGA-II's front and the
    acceptance box (paper Fig. 6). errors: ``study.analysis.ModelErrors`` of the sample's designs drawn (all of
    its n_designs, or its first ones, said in the legend); fronts: ``study.workflow.Fronts``."""
    label = "sample" if len(errors.design) == n_designs else f"sample (first {len(errors.design):,} of {n_designs:,})"
    columns = min(3, len(names))
    rows = -(-len(names) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.8 * rows), squeeze=False)
    for axis in axes.ravel()[len(names):]:
        axis.set_visible(False)
    for index, (axis, name) in enumerate(zip(axes.ravel(), names)):
        axis.loglog(errors.frequency_error_hz[:, index], errors.damping_error[:, index], ".", ms=1.5,
                    color="0.75", label=label, rasterized=True)
        front = fronts.sample[index]
        axis.loglog(front.frequency_error_hz, front.damping_error, "o-", ms=3, color="C0", label="sample front")
        nsga = fronts.nsga2_errors[index]
        order = np.argsort(nsga[:, 0])
        axis.loglog(nsga[order, 0], nsga[order, 1], "s--", ms=3, color="C3", label="NSGA-II front")
        axis.axvline(acceptance.frequency_tolerance_hz, color="k", lw=0.8)
        axis.axhline(acceptance.damping_tolerance, color="k", lw=0.8)
        axis.set(title=name, xlabel="L-inf frequency error (Hz)", ylabel="L-inf damping error (-)")
    axes[0, 0].legend(fontsize=7, loc="lower left")  # a fixed place: "best" scans every sample point
    figure.suptitle(f"{model}: Pareto fronts in the error plane")
    figure.tight_layout()
    save(figure, destination)


def plot_responses(destination: Path, model: str, curves, title: str | None = None, rule: str = "added",
                   device: str = "cpu") -> None:
    """Frequency and damping against modal amplitude: the measurement (labelled virtual where it is) and the
    QSMA backbones of representative designs, solved on ``device`` (``nonlinear.compute_devices``). curves: per
    structure (Structure, design indices, designs (k, d), the damping case's value made zeta_0 by ``rule``,
    ``study.errors.structure_damping``); title: the figure's (default: the study's representative Pareto
    designs)."""
    figure, axes = plt.subplots(2, len(curves), figsize=(4.2 * len(curves), 6.0), squeeze=False)
    for column, (structure, indices, designs, zeta0) in enumerate(curves):
        measurement = structure.measurement
        label = f"{measurement.provenance} measurement"
        axes[0, column].semilogx(measurement.amplitude, measurement.frequency_hz, "ko", ms=3, label=label)
        axes[1, column].semilogx(measurement.amplitude, measurement.damping, "ko", ms=3, label=label)
        if len(designs):
            amplitude = np.geomspace(measurement.amplitude[0], measurement.amplitude[-1], 40)
            result = qsma_designs(structure.space, model, designs, amplitudes=amplitude, linear_damping=0.0,
                                  device=device)
            damping = result.damping + structure_damping(result.damping, [zeta0], rule)
            for k, index in enumerate(indices):
                axes[0, column].semilogx(amplitude, result.frequency[k] / (2 * np.pi), label=f"design {index}")
                axes[1, column].semilogx(amplitude, damping[k], label=f"design {index}")
        for axis in axes[:, column]:
            axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        axes[0, column].set(title=structure.name, ylabel="natural frequency (Hz)")
        axes[1, column].set(xlabel="modal amplitude (m kg^0.5)", ylabel="damping ratio (-)")
        axes[0, column].legend(fontsize=7)
    figure.suptitle(title or f"{model}: representative Pareto designs against the measurement")
    figure.tight_layout()
    save(figure, destination)


def plot_confidence_against_scale(destination: Path, model: str, names, scales, sweep, chosen) -> None:
    """SC_IJ against a common factor k on every structure's own acceptance bounds (each structure accepts a design
    when both its errors are within k times its bounds), one panel per surrogate I: the study's sample (line,
    95 % band where it accepted a design) and subset simulation at the chosen bounds k = 1 (points with their
    95 % interval); the chosen bounds dashed.

    scales: (a,) factors k; sweep: ``study.surrogacy.SurrogacyMatrix`` of the sample with leading axis (a,);
    chosen: the ``surrogacy confidence`` table (``study.subset_simulation.SUBSET_COLUMNS``), rows (I, J)."""
    columns = min(3, len(names))
    rows = -(-len(names) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows), squeeze=False, sharey=True)
    for axis in axes.ravel()[len(names):]:
        axis.set_visible(False)
    ticks = [k for k in (0.5, 1, 2, 4, 8, 16) if scales[0] <= k <= scales[-1]]
    for surrogate, (axis, name) in enumerate(zip(axes.ravel(), names)):
        estimates = chosen[chosen["surrogate"] == name].set_index("real")
        for real, other in enumerate(names):
            if real == surrogate:
                continue
            line, = axis.plot(scales, sweep.confidence[:, surrogate, real], "-", lw=1.2, label=other)
            axis.fill_between(scales, sweep.lower[:, surrogate, real], sweep.upper[:, surrogate, real],
                              color=line.get_color(), alpha=0.15)
            if other in estimates.index and np.isfinite(estimates.loc[other, "confidence"]):
                value = estimates.loc[other]
                axis.errorbar([1.0], [value["confidence"]], yerr=[[value["confidence"] - value["lower"]],
                                                                   [value["upper"] - value["confidence"]]],
                              fmt="o", ms=4, capsize=3, color=line.get_color())
        axis.axvline(1.0, color="k", ls="--", lw=0.8)
        axis.set(xscale="log", title=f"surrogate {name}", xlabel="factor k on each structure's bounds",
                 xlim=(scales[0], scales[-1]), ylim=(-0.02, 1.02))
        axis.set_xticks(ticks, [f"{k:g}" for k in ticks])
        axis.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        axis.legend(fontsize=7, title="real structure", title_fontsize=7)
    for axis in axes[:, 0]:
        axis.set_ylabel("SC (surrogate for real)")
    figure.suptitle(f"{model}: surrogacy confidence against the bounds from the data (lines: the study's sample; "
                    "points: subset simulation at k = 1)", fontsize=9)
    figure.tight_layout()
    save(figure, destination)
