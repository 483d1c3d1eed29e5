"""The discrepancy loop on files: its input read from a measured backbone (the one-mode route, ``discrepancy.loop``,
from the nominal of ``discrepancy.nominal``) or from a study's structure (``discrepancy.superelement_route``), the
loop run and its verdict written with the record of what it ran on (``discrepancy.files``).
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Callable, NamedTuple

from discrepancy.files import write_verdict
from discrepancy.fitted_model import model_record
from discrepancy.loop import Verdict, discrepancy_loop, with_findings
from discrepancy.nominal import nominal_record
from discrepancy.superelement_route import from_study, structure_discrepancy_loop
from experiment.backbone import ModeBackbone, unphysical_points
from experiment.measured_files import read_mode_backbone
from experiment.signal_checks import drift_corrected
from reduction.superelement import StructureError
from study.structures import BackboneLevels, measured_levels


class LoopInput(NamedTuple):
    """What one run of the loop reads: the measurement at its levels, its ``source`` as the report names it, the
    record's fields known before the loop runs, the ``loop`` (no arguments -> ``discrepancy.loop.Verdict``), the
    signal checks' ``findings`` (``found``, ``checked``; empty for a study's structure) and the amplitude unit of the
    one-mode model's final record (None for a study's structure: the superelement route writes no final model)."""

    measurement: BackboneLevels
    source: str
    record: dict
    loop: Callable[[], Verdict]
    findings: dict
    amplitude_unit: str | None


def backbone_levels(measured: ModeBackbone, levels: int, path: Path) -> BackboneLevels:
    """The measured backbone binned to ``levels`` (``study.structures.measured_levels``). A point no free decay
    gives (``experiment.backbone.unphysical_points``: negative damping, no estimate, a frequency outside the band
    the settings name) raises StructureError naming the point and its cause; ``surrogacy freevib`` leaves such
    points out of the backbones it writes."""
    settings = measured.settings
    band = (settings.get("band") or ([0.7 * settings["mode_hz"], 1.3 * settings["mode_hz"]]
                                     if "mode_hz" in settings else None))
    reasons = unphysical_points(measured.backbone, band)
    if reasons:
        index, reason = next(iter(reasons.items()))
        raise StructureError(f"{path}: point {index + 1} of {measured.backbone.amplitude.size} (amplitude "
                             f"{measured.backbone.amplitude[index]:.4g} {measured.amplitude_unit}): {reason}"
                             + (f" (and {len(reasons) - 1} more such point(s))" if len(reasons) > 1 else "")
                             + "; remove its row, or rewrite the backbone with surrogacy freevib, which leaves such "
                               "points out with the reason")
    return measured_levels(measured, levels, str(path))


def measured_input(path: Path, levels: int, nominal_frequency_hz: float | None,
                   nominal_damping: float | None) -> LoopInput:
    """The one-mode loop on the measured backbone file ``path`` (any backbone format of
    ``experiment.measured_files``) binned to ``levels``, from the nominal low-amplitude frequency (Hz) and linear
    damping ratio given, each estimated from the measurement where None (``discrepancy.nominal.nominal_record``).
    A drift within each hit that the ring-down's signal checks found is taken out of the backbone first
    (``experiment.signal_checks.drift_corrected``; the record's ``drift_correction``): the loop fits the backbone
    as at each hit's impact, and the verdict stays unexplained by the finding."""
    measured, drift = drift_corrected(read_mode_backbone(path))
    measurement = backbone_levels(measured, levels, path)
    nominal = nominal_record(measurement, nominal_frequency_hz, nominal_damping)
    record = {"source": str(path), "provenance": measured.provenance, **nominal, "dropped_points": measured.dropped,
              "drift_correction": drift}
    loop = partial(discrepancy_loop, measurement, nominal["nominal_frequency_hz"], nominal["nominal_damping"],
                   nominal_uncertainty=(nominal["nominal_frequency_standard_error_hz"],
                                        nominal["nominal_damping_standard_error"]))
    return LoopInput(measurement, f"{path} ({measured.provenance})", record, loop, measured.findings,
                     measured.amplitude_unit)


def study_input(folder: Path, structure: str) -> LoopInput:
    """The superelement route's loop on the structure named ``structure`` of the analysed study in ``folder``:
    its superelement, with the study's friction models as the reference (``discrepancy.superelement_route``)."""
    loaded = from_study(folder, structure)
    measurement = loaded.measurement
    record = {"study": str(folder), "structure": structure, "provenance": measurement.provenance,
              "borrowed_damping": loaded.borrowed_damping, "damping_rule": loaded.damping_rule,
              "candidates": {model: len(c.labels) for model, c in loaded.candidates.items()}}
    loop = partial(structure_discrepancy_loop, measurement, loaded.candidates, loaded.borrowed_damping,
                   loaded.space, loaded.damping_rule)
    return LoopInput(measurement, f"{structure} of {folder} ({measurement.provenance})", record, loop, {}, None)


def run_loop(loop_input: LoopInput, out: Path) -> tuple[Verdict, dict]:
    """Run the loop, with the signal checks' findings beside its verdict (``discrepancy.loop.with_findings``), and
    write discrepancy.md, .png and .json into ``out`` (``discrepancy.files.write_verdict``); the record written
    holds the checks run and, for the one-mode route, the final model (``discrepancy.fitted_model.model_record``).
    Returns the verdict and the record."""
    verdict = with_findings(loop_input.loop(), loop_input.findings.get("found", []))
    record = {**loop_input.record, "signal_checks": loop_input.findings.get("checked", [])}
    if loop_input.amplitude_unit is not None:
        record["final_model"] = {**model_record(verdict.final, loop_input.measurement, record["nominal_frequency_hz"],
                                                record["nominal_damping"]),
                                 "amplitude_unit": loop_input.amplitude_unit}
    write_verdict(out, verdict, loop_input.measurement, loop_input.source, record)
    return verdict, record
