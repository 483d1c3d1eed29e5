"""Ring-down (free-decay) files: readers and writers for CSV, MATLAB .mat and Universal File Format 58.

Every reader returns a list of :class:`~experiment.ringdown.RingDown`, one per hit (impact), each holding a
uniformly sampled time vector and one or more sensor channels converted to SI units. Units are read from the
file and checked against a fixed table (:data:`SIGNAL_UNITS`, :data:`TIME_UNITS`); anything the table does not
know is refused rather than guessed. Every problem with a file raises :class:`~experiment.ringdown.RingDownError`
(a ``ValueError``) naming the file, the field and the problem.

File layouts
------------
CSV
    One header row ``time [s], <channel> [<unit>], ...`` (``#`` comment lines before it are skipped), an
    optional integer column ``hit`` that groups rows into hits (each hit with its own time vector), and the
    samples below, comma separated.
MATLAB .mat
    Either one struct (or struct array, one element per hit) or plain top-level variables, with a field
    ``time``, a string ``units`` of the form ``"<time unit>, <signal unit>"`` (e.g. ``"s, m/s^2"``, the layout
    of the Chen et al. 2022 ``HIdata`` struct), and one numeric field per channel: a vector of the time's length,
    or a matrix (samples x hits) for several hits.
UFF 58
    Time-response records (function type 1). The abscissa and ordinate unit labels are required; the
    ordinate specific data type (8 displacement, 11 velocity, 12 acceleration), when given, must agree with
    the label. Records are grouped into hits by load case, and named by response node and direction.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import scipy.io

from experiment.ringdown import RingDown, RingDownError
from pipeline.files import atomic_path, write_mat

STANDARD_GRAVITY = 9.80665
"""m/s^2, for accelerations recorded in g."""

TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Time unit label -> factor to seconds."""

SIGNAL_UNITS = {
    "m": ("displacement", 1.0), "mm": ("displacement", 1e-3), "um": ("displacement", 1e-6),
    "m/s": ("velocity", 1.0), "mm/s": ("velocity", 1e-3),
    "m/s^2": ("acceleration", 1.0), "m/s2": ("acceleration", 1.0), "m/s**2": ("acceleration", 1.0),
    "mm/s^2": ("acceleration", 1e-3), "g": ("acceleration", STANDARD_GRAVITY),
}
"""Signal unit label -> (measured quantity, factor to SI: m, m/s or m/s^2)."""

SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}
"""Quantity -> the SI unit label the writers use."""

UFF_SPECIFIC_DATA_TYPE = {8: "displacement", 11: "velocity", 12: "acceleration"}
"""UFF 58 ordinate specific data type codes of the quantities a ring-down may hold."""

UNIFORM_SAMPLING_TOLERANCE = 0.01
"""Largest deviation of a sample time from the uniform grid through the first and last samples, as a fraction of
the time step. The Hilbert transform needs uniform sampling. A logger samples uniformly, but a time column written
with few digits is not: rounded to 1 us at 12.8 kHz, its times lie up to 0.5 us (0.0064 of the 78 us step) off
the grid, and its steps differ by 1 us. Within the tolerance the time is read as the uniform grid it rounds: a
timing error of 1 % of a step is a phase error below 2 pi / 800 at the 8 samples per period FreeVib needs at
least. A missing or doubled sample moves the times by half a step or more and is refused."""


def time_factor(source, field: str, label: str) -> float:
    """Factor converting a time recorded in unit ``label`` to seconds."""
    key = label.strip()
    if key not in TIME_UNITS:
        raise RingDownError(source, field, f"unit '{label}' is not a time unit (known: {sorted(TIME_UNITS)})")
    return TIME_UNITS[key]


def signal_quantity(source, field: str, label: str) -> tuple[str, float]:
    """(quantity, factor to SI) of a signal recorded in unit ``label``."""
    key = label.strip().replace(" ", "")
    if key not in SIGNAL_UNITS:
        raise RingDownError(source, field,
                                f"unit '{label}' is not a displacement, velocity or acceleration unit "
                                f"(known: {sorted(SIGNAL_UNITS)})")
    return SIGNAL_UNITS[key]


def checked_time(source, field: str, time) -> np.ndarray:
    """The time vector as the uniform grid (n,) it records, after checking it is finite, strictly increasing and
    within ``UNIFORM_SAMPLING_TOLERANCE`` of that grid; same unit as ``time``."""
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or time.size < 3:
        raise RingDownError(source, field, f"expected a vector of at least 3 samples, got shape {time.shape}")
    if not np.all(np.isfinite(time)):
        raise RingDownError(source, field, f"{np.count_nonzero(~np.isfinite(time))} samples are NaN or infinite")
    step = np.diff(time)
    if np.any(step <= 0):
        first = int(np.flatnonzero(step <= 0)[0])
        raise RingDownError(source, field, f"not strictly increasing: sample {first + 1} at {time[first + 1]!r} "
                                               f"follows {time[first]!r}")
    mean_step = (time[-1] - time[0]) / (time.size - 1)
    grid = time[0] + np.arange(time.size) * mean_step
    deviation = np.max(np.abs(time - grid)) / mean_step
    if deviation > UNIFORM_SAMPLING_TOLERANCE:
        raise RingDownError(source, field, f"not uniformly sampled: sample times lie up to {deviation:.2g} of a "
                                           f"time step off the uniform grid; at most {UNIFORM_SAMPLING_TOLERANCE:g} "
                                           "is accepted (a time column rounded to its last digit)")
    return grid


def checked_signal(source, field: str, values, n_samples: int) -> np.ndarray:
    """The channel samples as float (n_samples,) after checking length and finiteness."""
    values = np.asarray(values, dtype=float)
    if values.shape != (n_samples,):
        raise RingDownError(source, field, f"expected {n_samples} samples like the time vector, got shape "
                                               f"{values.shape}")
    bad = ~np.isfinite(values)
    if np.any(bad):
        raise RingDownError(source, field, f"{np.count_nonzero(bad)} samples are NaN or infinite "
                                               f"(first at index {int(np.flatnonzero(bad)[0])})")
    return values


def checked_ring_down(source, hit: str, time, time_unit: str, channels: dict, signal_units: dict) -> RingDown:
    """Assemble one checked hit in SI units.

    channels: name -> samples; signal_units: name -> unit label. All channels must measure one quantity.
    """
    time_s = checked_time(source, "time", time) * time_factor(source, "time", time_unit)
    quantities = {name: signal_quantity(source, name, signal_units[name]) for name in channels}
    kinds = {quantity for quantity, _ in quantities.values()}
    if len(kinds) != 1:
        raise RingDownError(source, ", ".join(channels), f"channels mix quantities {sorted(kinds)}; "
                                                             "one ring-down must hold one quantity")
    signals = np.array([checked_signal(source, name, values, time_s.size) * quantities[name][1]
                        for name, values in channels.items()])
    return RingDown(time_s, signals, tuple(channels), kinds.pop(), str(source), hit)


def split_label(source, header: str) -> tuple[str, str]:
    """A CSV column header ``name [unit]`` split into (name, unit)."""
    name, bracket, rest = header.partition("[")
    if not bracket or not rest.rstrip().endswith("]"):
        raise RingDownError(source, header.strip(), "column header must read 'name [unit]'")
    return name.strip(), rest.rstrip()[:-1].strip()


def read_csv(path: Path) -> list[RingDown]:
    """Ring-down hits from a CSV file (layout in the module docstring)."""
    path = Path(path)
    with open(path, newline="", encoding="utf-8-sig") as stream:  # utf-8-sig: Excel's "CSV UTF-8" starts with a BOM
        lines = [line for line in stream if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise RingDownError(path, "header", "file holds no header row")
    if len(lines) == 1:
        raise RingDownError(path, "samples", "no sample rows below the header row")
    headers = [column.strip() for column in next(csv.reader(lines[:1]))]
    repeated = sorted({header for header in headers if headers.count(header) > 1})
    if repeated:
        raise RingDownError(path, ", ".join(repeated), "column named more than once (each column needs its own name)")
    try:
        table = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    except ValueError as error:
        raise RingDownError(path, "samples", f"not a table of numbers: {error}") from error
    if table.shape[1] != len(headers):
        raise RingDownError(path, "header", f"{len(headers)} headers for {table.shape[1]} columns")
    hit_column = headers.index("hit") if "hit" in headers else None
    labelled = [(index, *split_label(path, header)) for index, header in enumerate(headers) if index != hit_column]
    time_columns = [entry for entry in labelled if entry[1] == "time"]
    if len(time_columns) != 1:
        raise RingDownError(path, "time", "expected exactly one column 'time [unit]'")
    time_index, _, time_unit = time_columns[0]
    channel_columns = [entry for entry in labelled if entry[1] != "time"]
    if not channel_columns:
        raise RingDownError(path, "header", "no signal channel besides time")
    hit_ids = table[:, hit_column] if hit_column is not None else np.ones(len(table))
    records = []
    for hit in np.unique(hit_ids):
        rows = table[hit_ids == hit]
        channels = {name: rows[:, index] for index, name, _ in channel_columns}
        units = {name: unit for _, name, unit in channel_columns}
        records.append(checked_ring_down(path, f"hit {hit:g}", rows[:, time_index], time_unit, channels, units))
    return records


def mat_fields(container) -> dict:
    """Public fields of a loaded MATLAB struct or of the top-level variables of a .mat file."""
    if isinstance(container, dict):
        return {key: value for key, value in container.items() if not key.startswith("__")}
    return {name: getattr(container, name) for name in container._fieldnames}


def mat_hits(path: Path, fields: dict, hit_label: str) -> list[RingDown]:
    """Hits of one MATLAB struct element (or the top-level variables): ``time``, ``units`` and channels."""
    if "time" not in fields:
        raise RingDownError(path, "time", "missing (a field named 'time' holds the sample times)")
    if "units" not in fields or not isinstance(fields["units"], str) or fields["units"].count(",") != 1:
        raise RingDownError(path, "units", "missing or malformed: expected a string '<time unit>, <signal unit>'"
                                               ", e.g. 's, m/s^2'")
    time_unit, signal_unit = (part.strip() for part in fields["units"].split(","))
    complex_valued = [name for name, value in fields.items()
                      if isinstance(value, np.ndarray) and value.dtype.kind == "c"]
    if complex_valued:
        raise RingDownError(path, ", ".join(complex_valued), "complex values; expected real samples (a time signal, "
                                                              "not a spectrum)")
    time = np.asarray(fields["time"], dtype=float)
    columns = {name: value.reshape(value.shape[0], -1) for name, value in fields.items()
               if name not in ("time", "units") and isinstance(value, np.ndarray) and value.ndim in (1, 2)
               and value.dtype.kind in "fiu"}
    if not columns:
        raise RingDownError(path, "channels", "no numeric vector or matrix besides 'time'")
    n_hits = {matrix.shape[1] for matrix in columns.values()}
    if len(n_hits) != 1:
        raise RingDownError(path, ", ".join(columns), "channels hold different numbers of hits (columns)")
    n_hits = n_hits.pop()
    labels = [f"{hit_label} hit {hit + 1}" for hit in range(n_hits)] if n_hits > 1 else [hit_label]
    return [checked_ring_down(path, label, time, time_unit, {name: matrix[:, hit] for name, matrix in columns.items()},
                      dict.fromkeys(columns, signal_unit))
            for hit, label in enumerate(labels)]


def read_mat(path: Path) -> list[RingDown]:
    """Ring-down hits from a MATLAB .mat file (layout in the module docstring)."""
    path = Path(path)
    try:
        contents = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except (ValueError, OSError, scipy.io.matlab.MatReadError) as error:
        raise RingDownError(path, "file", f"not a readable MATLAB file: {error}") from error
    variables = mat_fields(contents)
    structs = {name: value for name, value in variables.items()
               if isinstance(value, scipy.io.matlab.mat_struct)
               or (isinstance(value, np.ndarray) and value.dtype == object and value.size
                   and all(isinstance(item, scipy.io.matlab.mat_struct) for item in value.flat))}
    if not structs:
        return mat_hits(path, variables, "variables")
    if len(structs) > 1:
        raise RingDownError(path, ", ".join(structs), "several structs; expected one holding the ring-down")
    name, value = next(iter(structs.items()))
    elements = [value] if isinstance(value, scipy.io.matlab.mat_struct) else list(value.flat)
    return [record for index, element in enumerate(elements)
            for record in mat_hits(path, mat_fields(element), f"{name}({index + 1})" if len(elements) > 1 else name)]


def read_uff58(path: Path) -> list[RingDown]:
    """Ring-down hits from Universal File Format 58 time-response records (layout in the module docstring)."""
    import pyuff

    path = Path(path)
    try:
        datasets = pyuff.UFF(str(path)).read_sets()
    except Exception as error:  # pyuff raises bare Exceptions for malformed files
        raise RingDownError(path, "file", f"not a readable universal file: {error}") from error
    datasets = [datasets] if isinstance(datasets, dict) else datasets
    records = [record for record in datasets if record.get("type") == 58 and record.get("func_type") == 1]
    if not records:
        raise RingDownError(path, "dataset 58", "no time-response record (dataset 58, function type 1)")
    hits = {}
    for record in records:
        channel = f"node {record['rsp_node']} dir {record['rsp_dir']}"
        unit = record.get("ordinate_axis_units_lab", "NONE").strip()
        if unit in ("", "NONE"):
            raise RingDownError(path, channel, "ordinate units label missing")
        quantity, _ = signal_quantity(path, channel, unit)
        coded = UFF_SPECIFIC_DATA_TYPE.get(record.get("ordinate_spec_data_type"))
        if coded is not None and coded != quantity:
            raise RingDownError(path, channel, f"units '{unit}' contradict the ordinate specific data type "
                                                   f"{record['ordinate_spec_data_type']} ({coded})")
        hits.setdefault(record.get("load_case_id", 0), []).append((channel, unit, record))
    result = []
    for hit, entries in hits.items():
        time = entries[0][2]["x"]
        time_unit = entries[0][2].get("abscissa_axis_units_lab", "NONE")
        for channel, _, record in entries[1:]:
            if record["x"].shape != time.shape or not np.array_equal(record["x"], time):
                raise RingDownError(path, channel, f"time samples differ from the other channels of load case "
                                                       f"{hit}")
        result.append(checked_ring_down(path, f"load case {hit}", time, time_unit,
                                {channel: record["data"] for channel, _, record in entries},
                                {channel: unit for channel, unit, _ in entries}))
    return result


def common_layout(ring_downs: list[RingDown], same_times: bool = True) -> RingDown:
    """The first hit, after checking that every hit has its channels and quantity, and with ``same_times`` its
    sample times (the layout a .mat struct with one column per hit needs; a CSV gives each hit its own times)."""
    first = ring_downs[0]
    for hit in ring_downs[1:]:
        if (hit.channels, hit.quantity) != (first.channels, first.quantity) or (
                same_times and not np.array_equal(hit.time, first.time)):
            raise RingDownError(hit.source, hit.hit, "channels, quantity or sample times differ from the first hit's")
    return first


def write_ringdown_csv(ring_downs: list[RingDown], destination: Path, comment: str | None = None,
                       provenance: str | None = None) -> None:
    """Write hits as one CSV (layout in the module docstring): a ``hit`` column numbering them from 1, time in s,
    signals in SI units, every number in Python's shortest round-tripping form; ``comment`` as a ``#`` line
    before the header (e.g. that the data are virtual) and ``provenance`` ("measured" or "virtual") as a
    ``# provenance: ...`` line. Each hit keeps its own sample times (e.g. the time since the first hit)."""
    first = common_layout(ring_downs, same_times=False)
    with atomic_path(destination) as temporary, open(temporary, "w", newline="") as stream:
        if comment is not None:
            stream.write(f"# {comment}\n")
        if provenance is not None:
            stream.write(f"# provenance: {provenance}\n")
        writer = csv.writer(stream)
        writer.writerow(["hit", "time [s]", *(f"{name} [{SI_UNITS[first.quantity]}]" for name in first.channels)])
        for number, hit in enumerate(ring_downs, start=1):
            writer.writerows([number, *row] for row in np.column_stack([hit.time, hit.signals.T]).tolist())


def write_ringdown_mat(ring_downs: list[RingDown], destination: Path, struct: str = "ringdown",
                       provenance: str | None = None) -> None:
    """Write hits as one MATLAB struct (layout in the module docstring): ``time``, ``units`` and one
    (n_samples, n_hits) matrix per channel. Channel names become MATLAB field names (characters other than
    letters, digits and ``_`` replaced by ``_``). ``provenance`` ("measured" or "virtual"), when given, is a
    top-level string variable of that name."""
    first = common_layout(ring_downs)
    fields = {"time": first.time, "units": f"s, {SI_UNITS[first.quantity]}"}
    for row, name in enumerate(first.channels):
        fields[re.sub(r"\W", "_", name)] = np.column_stack([hit.signals[row] for hit in ring_downs])
    with atomic_path(destination) as temporary:
        write_mat(temporary, {struct: fields} | ({"provenance": provenance} if provenance else {}))  # no time stamp


def write_ringdown_uff58(ring_downs: list[RingDown], destination: Path) -> None:
    """Write hits as UFF 58 time-response records (function type 1, ASCII): load case = hit number from 1,
    response node = channel number from 1 (direction 1), the channel name in ID line 1, SI units."""
    import pyuff

    data_type = {quantity: code for code, quantity in UFF_SPECIFIC_DATA_TYPE.items()}
    datasets = [pyuff.prepare_58(func_type=1, load_case_id=number, rsp_node=node, rsp_dir=1, ref_node=0, ref_dir=0,
                                 id1=name, x=hit.time, data=signal, abscissa_spacing=1, abscissa_spec_data_type=17,
                                 abscissa_axis_units_lab="s", ordinate_axis_units_lab=SI_UNITS[hit.quantity],
                                 ordinate_spec_data_type=data_type[hit.quantity],
                                 orddenom_spec_data_type=0, z_axis_spec_data_type=0, binary=0)
                for number, hit in enumerate(ring_downs, start=1)
                for node, (name, signal) in enumerate(zip(hit.channels, hit.signals), start=1)]
    with atomic_path(destination) as temporary:
        pyuff.UFF(str(temporary)).write_sets(datasets, mode="overwrite")


def read_mode_shapes(path: Path) -> np.ndarray:
    """Mode shapes at the sensors from a CSV of n_channels rows and n_modes columns (``#`` comments allowed)."""
    try:
        return np.loadtxt(path, delimiter=",", ndmin=2, comments="#")
    except (OSError, ValueError) as error:
        raise RingDownError(path, "mode shapes", f"not a readable table of numbers: {error}") from error

