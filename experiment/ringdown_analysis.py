"""Ring-downs to a study's backbone in one call: the chain that ``surrogacy freevib``, the examples and the virtual
experiments share (docs/design.md section 6).

:func:`analyse_ringdown` runs :func:`experiment.backbone.ringdown_backbone` (settings checked, the band-pass below
every hit's Nyquist frequency), the checks of the signals for what a backbone hides
(:func:`experiment.signal_checks.ringdown_findings`, on the channels the backbone is made of), and labels the Hilbert
backbone for a study (:func:`experiment.backbone.mode_backbone`: structure, provenance, settings, findings, the
points no free decay gives left out); :func:`analyse_ringdown_file` does so for the hits of one file, with the
file's SHA-256 recorded in the backbone's settings.
"""

from __future__ import annotations

from pathlib import Path

from experiment.backbone import ModeBackbone, RingDownBackbones, mode_backbone, ringdown_backbone
from experiment.ringdown import RingDown, selected_channels
from experiment.signal_checks import ringdown_findings
from pipeline.files import sha256_file


def analyse_ringdown(hits: list[RingDown], mode_frequency_hz: float, structure: str, provenance: str, *,
                     settings: dict | None = None, check_signals: bool = True, **options
                     ) -> tuple[ModeBackbone, RingDownBackbones]:
    """The backbone of one mode of ring-downs, labelled for a study, and both estimators behind it.

    hits: ring-downs of one structure with the same channels, measured or simulated. mode_frequency_hz: guess of
    the mode's natural frequency, Hz. structure, provenance: the labels of the backbone
    (``experiment.backbone.PROVENANCES``). settings: how the backbone was estimated, recorded with it.
    check_signals: run the signal checks (``ringdown_findings``); a virtual experiment's simulated hits start at
    the impact and pass through no instrument, so the record checks would report what the simulation is by
    construction. options: keywords of :func:`experiment.backbone.ringdown_backbone` (band_hz, mode_shapes,
    mode_index, per_channel, channels, grid_points, cycles, seed, and FreeVib's smoothing_periods, trim_periods,
    feldman).

    Returns (the labelled Hilbert backbone, ``ModeBackbone``; both estimators on one grid, ``RingDownBackbones``).
    Raises BackboneSettingError for a setting out of range, RingDownError for a record that gives no backbone.
    """
    measured = ringdown_backbone(hits, mode_frequency_hz, **options)
    channels = options.get("channels")
    used = [selected_channels(hit, channels) for hit in hits] if channels else hits
    findings = ringdown_findings(used, measured, measured.band_hz) if check_signals else None
    return mode_backbone(measured, structure, provenance, settings, findings), measured


def analyse_ringdown_file(source: Path, hits: list[RingDown], mode_frequency_hz: float, provenance: str,
                          settings: dict, **options) -> tuple[ModeBackbone, RingDownBackbones]:
    """:func:`analyse_ringdown` on the ``hits`` read from the file ``source``, the backbone labelled with the file's
    stem and its ``settings`` joined by the file's SHA-256 (``source_sha256``), so that the backbone names the
    bytes it was estimated from. options: as :func:`analyse_ringdown`'s."""
    return analyse_ringdown(hits, mode_frequency_hz, Path(source).stem, provenance,
                            settings=settings | {"source_sha256": sha256_file(source)}, **options)
