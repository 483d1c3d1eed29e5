"""Backbone files: the documented backbone CSV that studies read, the ASB measured backbones, and the
freevib command's table and figure.

Backbone CSV (one mode of one structure; :func:`write_backbone`, :func:`read_backbone`)
--------------------------------------------------------------------------------------
Comment lines ``# key: value`` first, in this order::

    # backbone: natural frequency and damping ratio of one mode against its amplitude
    # structure: <name, e.g. ASB C1>
    # low_amplitude_frequency_hz: <the mode's natural frequency at the lowest amplitude with data, Hz>
    # amplitude_unit: <unit of the amplitude column, e.g. m kg^0.5 for a mass-normalised modal amplitude>
    # provenance: <measured | virtual>
    # source: <file (and hash) or model and design it was obtained from>
    # settings: <optional: the estimation's settings as one JSON object, e.g. those of surrogacy freevib>
    # findings: <optional: the signal checks beside the backbone as one JSON object {"checked": [...], "found": [...]}>
    # dropped: <optional: the estimates left out because no free decay gives them, one JSON list of
    #           {"amplitude", "natural_frequency_hz", "damping_ratio", "records", "reason"}>

then one header row of :data:`BACKBONE_COLUMNS` (``name [unit]``, comma separated) and one row per amplitude,
in increasing amplitude:

    modal_amplitude [amplitude_unit]; natural_frequency [Hz]; natural_frequency_spread [Hz] (standard deviation
    over hits or channels); natural_frequency_standard_error [Hz] (the standard error of the point's mean, the
    estimator's noise); damping_ratio [-] (fraction of critical); damping_ratio_spread [-];
    damping_ratio_standard_error [-]; records [-] (number of hits or channels behind the point).

Unknown values are written ``nan`` (e.g. the spread of a single record). Numbers are written with Python's
shortest round-tripping representation, so reading a written file gives the same floats.

ASB measured backbones (:func:`read_asb_backbone`)
--------------------------------------------------
``ASB_<configuration>_20Nm_BB.mat`` (Nidish96/Computational-Work-For-ASB-Project, EXP_DATA): vectors ``Q``
(mass-normalised modal amplitude, m kg^0.5), ``W`` (natural frequency, Hz), ``Z`` (damping ratio), one point
per estimate, without spread.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import scipy.io

from experiment.backbone import PROVENANCES, Backbone, ModeBackbone, RingDownBackbones, low_amplitude_reference
from pipeline.files import atomic_path, json_text, write_json

BACKBONE_TITLE = "backbone: natural frequency and damping ratio of one mode against its amplitude"
"""First comment line of a backbone CSV."""

BACKBONE_KEYS = ("structure", "low_amplitude_frequency_hz", "amplitude_unit", "provenance", "source")
"""Header keys of a backbone CSV, in order: the fields of :class:`~experiment.backbone.ModeBackbone`."""

BACKBONE_COLUMNS = (
    ("modal_amplitude", "{unit}", "amplitude"),
    ("natural_frequency", "Hz", "natural_frequency_hz"),
    ("natural_frequency_spread", "Hz", "natural_frequency_spread_hz"),
    ("natural_frequency_standard_error", "Hz", "natural_frequency_standard_error_hz"),
    ("damping_ratio", "-", "damping_ratio"),
    ("damping_ratio_spread", "-", "damping_ratio_spread"),
    ("damping_ratio_standard_error", "-", "damping_ratio_standard_error"),
    ("records", "-", "n_records"),
)
"""Columns of a backbone CSV: name, unit, field of :class:`~experiment.backbone.Backbone`."""

ASB_MODAL_AMPLITUDE_UNIT = "m kg^0.5"
"""Unit of a mass-normalised modal amplitude q (u = phi q with phi^T M phi = 1)."""


def file_error(path, field: str, problem: str) -> ValueError:
    """A ValueError naming the file, the field and the problem."""
    return ValueError(f"{path}: field '{field}': {problem}")


def backbone_header(amplitude_unit: str) -> list[str]:
    """The column header row ``name [unit]`` of a backbone CSV."""
    return [f"{name} [{unit.format(unit=amplitude_unit)}]" for name, unit, _ in BACKBONE_COLUMNS]


def write_backbone(mode: ModeBackbone, destination: Path) -> None:
    """Write a backbone CSV (format in the module docstring)."""
    values = {"low_amplitude_frequency_hz": repr(mode.low_amplitude_frequency_hz)}
    with atomic_path(destination) as temporary, open(temporary, "w", newline="") as stream:
        stream.write(f"# {BACKBONE_TITLE}\n")
        stream.writelines(f"# {key}: {values.get(key, getattr(mode, key))}\n" for key in BACKBONE_KEYS)
        for key in ("settings", "findings", "dropped"):
            if getattr(mode, key):
                stream.write(f"# {key}: {json_text(getattr(mode, key), sort_keys=True)}\n")
        writer = csv.writer(stream)
        writer.writerow(backbone_header(mode.amplitude_unit))
        writer.writerows(zip(*(getattr(mode.backbone, field).tolist() for _, _, field in BACKBONE_COLUMNS)))


def read_backbone(path: Path) -> ModeBackbone:
    """Read a backbone CSV (format in the module docstring); a malformed file raises a ValueError naming it."""
    path = Path(path)
    with open(path, newline="") as stream:
        lines = stream.read().splitlines()
    comments = [line[1:].strip() for line in lines if line.startswith("#")]
    if not comments or comments[0] != BACKBONE_TITLE:
        raise file_error(path, "title", f"first line must read '# {BACKBONE_TITLE}'")
    header = dict(comment.partition(": ")[::2] for comment in comments[1:])
    missing = [key for key in BACKBONE_KEYS if key not in header]
    if missing:
        raise file_error(path, ", ".join(missing), "missing from the '# key: value' header")
    if header["provenance"] not in PROVENANCES:
        raise file_error(path, "provenance", f"'{header['provenance']}'; expected one of {', '.join(PROVENANCES)} "
                                             "(simulated data are virtual)")
    rows = [line for line in lines if line and not line.startswith("#")]
    if not rows or next(csv.reader(rows[:1])) != backbone_header(header["amplitude_unit"]):
        raise file_error(path, "columns", f"header row must read {','.join(backbone_header(header['amplitude_unit']))}")
    if len(rows) == 1:
        raise file_error(path, "rows", "none below the header row (expected one row per amplitude)")
    try:
        table = np.loadtxt(rows[1:], delimiter=",", ndmin=2).reshape(-1, len(BACKBONE_COLUMNS))
    except ValueError as error:
        raise file_error(path, "rows", f"not a table of {len(BACKBONE_COLUMNS)} numbers per row: {error}") from error
    columns = dict(zip((field for _, _, field in BACKBONE_COLUMNS), table.T))
    columns["n_records"] = columns["n_records"].astype(int)
    settings, findings = (json_line(path, header, key) for key in ("settings", "findings"))
    if findings and not (isinstance(findings.get("checked"), list) and isinstance(findings.get("found"), list)
                         and all({"name", "outside_library", "summary", "evidence"} <= set(entry)
                                 for entry in findings["found"])):
        raise file_error(path, "findings", "expected {\"checked\": [names], \"found\": [{\"name\", "
                                           "\"outside_library\", \"summary\", \"evidence\"}, ...]}")
    return ModeBackbone(header["structure"], float(header["low_amplitude_frequency_hz"]), header["amplitude_unit"],
                        header["provenance"], header["source"], Backbone(**columns), settings, findings,
                        dropped_points(path, header))


DROPPED_KEYS = {"amplitude", "natural_frequency_hz", "damping_ratio", "records", "reason"}
"""Keys of each entry of a backbone CSV's ``# dropped:`` line (:func:`experiment.backbone.physical_backbone`)."""


def dropped_points(path: Path, header: dict) -> list:
    """The entries of the optional ``# dropped: [...]`` line ([] where absent); a line that is not one JSON list
    of objects with :data:`DROPPED_KEYS` raises a ValueError naming the file and the key."""
    try:
        value = json.loads(header.get("dropped", "[]"))
    except json.JSONDecodeError as error:
        raise file_error(path, "dropped", f"not one JSON list: {error}") from error
    if not (isinstance(value, list) and all(isinstance(entry, dict) and DROPPED_KEYS <= set(entry)
                                            for entry in value)):
        raise file_error(path, "dropped", f"expected a JSON list of {{{', '.join(sorted(DROPPED_KEYS))}}} objects")
    return value


def json_line(path: Path, header: dict, key: str) -> dict:
    """The JSON object of an optional ``# <key>: {...}`` header line ({} where the line is absent); a line that is
    not one JSON object raises a ValueError naming the file and the key."""
    try:
        value = json.loads(header.get(key, "{}"))
    except json.JSONDecodeError as error:
        raise file_error(path, key, f"not one JSON object: {error}") from error
    if not isinstance(value, dict):
        raise file_error(path, key, "not one JSON object")
    return value


def read_asb_backbone(path: Path) -> ModeBackbone:
    """A measured ASB backbone (``ASB_<configuration>_20Nm_BB.mat``) as a :class:`~experiment.backbone.ModeBackbone`.

    The points are sorted by increasing amplitude (the file's order is that of the decay, with the estimates'
    scatter); each is one record without spread or standard error (NaN). The low-amplitude frequency is the
    natural frequency at the smallest amplitude.
    """
    path = Path(path)
    contents = scipy.io.loadmat(path)
    missing = [name for name in "QWZ" if name not in contents]
    if missing:
        raise file_error(path, ", ".join(missing), "missing (expected vectors Q, W, Z)")
    complex_valued = [name for name in "QWZ" if np.iscomplexobj(contents[name])]
    if complex_valued:
        raise file_error(path, ", ".join(complex_valued), "complex values; expected real vectors")
    amplitude, frequency, damping = (np.ravel(contents[name]).astype(float) for name in "QWZ")
    if not amplitude.size == frequency.size == damping.size:
        raise file_error(path, "Q, W, Z", f"lengths differ: {amplitude.size}, {frequency.size}, {damping.size}")
    order = np.argsort(amplitude, kind="stable")
    unknown = np.full(amplitude.size, np.nan)
    backbone = Backbone(amplitude[order], frequency[order], unknown, unknown, damping[order], unknown, unknown,
                        np.ones(amplitude.size, dtype=int))
    configuration = re.fullmatch(r"ASB_(.+)_20Nm_BB", path.stem)
    return ModeBackbone(f"ASB {configuration[1]}" if configuration else path.stem,
                        float(low_amplitude_reference(backbone.natural_frequency_hz)), ASB_MODAL_AMPLITUDE_UNIT,
                        "measured", str(path), backbone)


def freevib_stem(ringdown: Path, mode_hz: float) -> str:
    """The stem of the files ``surrogacy freevib`` writes for the mode near ``mode_hz`` (Hz) of the ring-down file
    ``ringdown``: ``<stem>_mode_<F>Hz``; its backbone CSV is ``<stem>_mode_<F>Hz_backbone.csv``."""
    return f"{Path(ringdown).stem}_mode_{mode_hz:g}Hz"


FREEVIB_COLUMNS = (
    ("amplitude", "{unit}", lambda b: b.hilbert.amplitude),
    ("records", "-", lambda b: b.hilbert.n_records),
    ("natural_frequency_hilbert", "Hz", lambda b: b.hilbert.natural_frequency_hz),
    ("natural_frequency_hilbert_spread", "Hz", lambda b: b.hilbert.natural_frequency_spread_hz),
    ("natural_frequency_hilbert_uncertainty", "Hz", lambda b: b.hilbert.natural_frequency_uncertainty_hz),
    ("damping_ratio_hilbert", "-", lambda b: b.hilbert.damping_ratio),
    ("damping_ratio_hilbert_spread", "-", lambda b: b.hilbert.damping_ratio_spread),
    ("damping_ratio_hilbert_uncertainty", "-", lambda b: b.hilbert.damping_ratio_uncertainty),
    ("natural_frequency_cycles", "Hz", lambda b: b.cycles.natural_frequency_hz),
    ("natural_frequency_cycles_spread", "Hz", lambda b: b.cycles.natural_frequency_spread_hz),
    ("natural_frequency_cycles_uncertainty", "Hz", lambda b: b.cycles.natural_frequency_uncertainty_hz),
    ("damping_ratio_cycles", "-", lambda b: b.cycles.damping_ratio),
    ("damping_ratio_cycles_spread", "-", lambda b: b.cycles.damping_ratio_spread),
    ("damping_ratio_cycles_uncertainty", "-", lambda b: b.cycles.damping_ratio_uncertainty),
)
"""Columns of the freevib table: name, unit, value."""


def write_freevib_table(backbone: RingDownBackbones, destination: Path) -> None:
    """Write both estimators' averaged backbones as CSV, header ``name [unit]`` (the freevib command's table).

    spread: standard deviation over records (hits, channels); uncertainty: the mean's, the larger of spread /
    sqrt(records) and the estimator's standard error (:func:`~experiment.backbone.mean_uncertainty`).
    """
    with atomic_path(destination) as temporary, open(temporary, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow([f"{name} [{unit.format(unit=backbone.amplitude_unit)}]" for name, unit, _ in FREEVIB_COLUMNS])
        writer.writerows(zip(*(np.asarray(value(backbone)) for _, _, value in FREEVIB_COLUMNS)))


def plot_backbone(backbone: RingDownBackbones, destination: Path) -> None:
    """Paper Fig. 3 style PNG: frequency deviation (%) and damping deviation from the low-amplitude values
    against amplitude on a log axis; Hilbert mean with its spread shaded, cycle estimates with error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (frequency_axis, damping_axis) = plt.subplots(2, 1, sharex=True, figsize=(6, 6))
    f0 = low_amplitude_reference(backbone.hilbert.natural_frequency_hz)
    z0 = low_amplitude_reference(backbone.hilbert.damping_ratio)
    for estimate, name, style in ((backbone.hilbert, "Hilbert (FreeVib)", "-"), (backbone.cycles, "cycles", "o")):
        frequency = 100 * (estimate.natural_frequency_hz / f0 - 1)
        frequency_spread = np.nan_to_num(100 * estimate.natural_frequency_spread_hz / f0)
        damping, damping_spread = estimate.damping_ratio - z0, np.nan_to_num(estimate.damping_ratio_spread)
        if style == "-":
            frequency_axis.plot(estimate.amplitude, frequency, style, label=name)
            frequency_axis.fill_between(estimate.amplitude, frequency - frequency_spread,
                                        frequency + frequency_spread, alpha=0.3)
            damping_axis.plot(estimate.amplitude, damping, style, label=name)
            damping_axis.fill_between(estimate.amplitude, damping - damping_spread, damping + damping_spread,
                                      alpha=0.3)
        else:
            frequency_axis.errorbar(estimate.amplitude, frequency, frequency_spread, fmt=style, ms=3, label=name)
            damping_axis.errorbar(estimate.amplitude, damping, damping_spread, fmt=style, ms=3, label=name)
    frequency_axis.set_ylabel("frequency deviation (%)")
    damping_axis.set_ylabel("damping deviation (-)")
    damping_axis.set_xlabel(f"amplitude ({backbone.amplitude_unit})")
    damping_axis.set_xscale("log")
    frequency_axis.set_title(f"{Path(backbone.source).name}\nlow-amplitude {f0:.3f} Hz, damping ratio {z0:.2e}",
                             fontsize=10)
    frequency_axis.legend()
    figure.tight_layout()
    with atomic_path(destination) as temporary:
        figure.savefig(temporary, dpi=120, format="png")
    plt.close(figure)


def freevib_record(source: Path, mode: ModeBackbone, backbone: RingDownBackbones) -> dict:
    """The JSON sidecar of ``surrogacy freevib``'s files for the ring-down file ``source``: the file and its SHA-256,
    the settings the backbone ``mode`` was estimated with (``experiment.ringdown_analysis.analyse_ringdown_file``),
    the amplitude unit, the records averaged, the mode shape at the channels, the signal checks' findings and the
    points left out of the backbone; ``backbone`` holds both estimators."""
    settings = {key: value for key, value in mode.settings.items() if key != "source_sha256"}
    return {"source": str(source), "source_sha256": mode.settings["source_sha256"], "settings": settings,
            "amplitude_unit": backbone.amplitude_unit, "records": [record.label for record in backbone.records],
            "mode_shape": {name: float(value) for name, value in backbone.shape.items()}, "findings": mode.findings,
            "dropped": mode.dropped}


def write_freevib(out: Path, source: Path, mode_hz: float, mode: ModeBackbone, backbone: RingDownBackbones) -> str:
    """``surrogacy freevib``'s files for the mode near ``mode_hz`` (Hz) of the ring-down file ``source`` into
    ``out``: the backbone CSV of ``mode`` (``write_backbone``), both estimators of ``backbone`` as a table
    (``write_freevib_table``) and a plot (``plot_backbone``), and the JSON sidecar (``freevib_record``). Returns the
    files' stem (``freevib_stem``)."""
    stem = freevib_stem(source, mode_hz)
    write_backbone(mode, out / f"{stem}_backbone.csv")
    write_freevib_table(backbone, out / f"{stem}.csv")
    plot_backbone(backbone, out / f"{stem}.png")
    write_json(out / f"{stem}.json", freevib_record(source, mode, backbone))
    return stem
