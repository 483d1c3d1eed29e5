"""The published numbers the pipeline needs, each beside its source: the defaults of every stage that compares
with or is tuned to the paper. A user's own tables replace them where a command takes ``--reference FOLDER``
(the files are named in ``TABLE_FILES``).

The paper: N. N. Balaji, M. R. W. Brake, "The surrogate system hypothesis for joint mechanics", Mechanical
Systems and Signal Processing 126 (2019) 42-64, doi:10.1016/j.ymssp.2019.02.013.

The nominal Brake-Reuss beam: the public ABAQUS input deck of the BRB (repository Nidish96/octave-jim,
MODELS/BRB/BRB_MATEX.inp) and its engineering drawings (Nidish96/Abaqus4Joints).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple


@dataclass(frozen=True)
class LowAmplitude:
    """One row of the paper's Table 1: the first out-of-plane bending mode's low-amplitude frequency (Hz) and
    damping factor (fraction of critical) of one beam."""

    beam: str
    frequency_hz: float
    damping: float


TABLE1 = {row.beam: row for row in (LowAmplitude("BRB", 169.48, 1665.9340e-6),
                                    LowAmplitude("LBRB", 80.82, 924.3096e-6),
                                    LowAmplitude("SBRB", 91.96, 946.0959e-6))}
"""Paper Table 1, "Mean low amplitude modal parameters for the first out-of-plane bending mode of the different
beam configurations" (section 2): beam -> LowAmplitude."""

TABLE3 = {"F_S": (1e1, 1e11, True), "K_T": (1e2, 1e14, True), "chi": (-0.99, -0.01, False),
          "beta": (1e-4, 1e4, True), "theta": (0.0, 1.0, False), "K_z": (1e2, 1e14, True)}
"""Paper Table 3, "Parameter limits for design exploration" (section 5.2.1): parameter -> (minimum, maximum,
sampled in log scale). F_S in N, K_T and K_z in N/m, chi, beta and theta dimensionless."""

TABLE3_UNITS = {"F_S": "N", "K_T": "N/m", "chi": "-", "beta": "-", "theta": "-", "K_z": "N/m"}
"""The unit of each of Table 3's parameters."""

TABLE5_BEAMS = ("BRB", "LBRB", "SBRB")
"""The order of Table 5's rows (surrogate) and columns (real)."""

TABLE5 = tuple((model, surrogate, real, matrix[i][j]) for model, matrix in (
    ("jenkins", ((1.000000, 0.985275, 0.845466), (0.348352, 1.000000, 0.773051), (0.050213, 0.129858, 1.000000))),
    ("iwan4", ((1.000000, 0.988733, 0.860906), (0.353605, 1.000000, 0.779876), (0.052984, 0.134206, 1.000000))),
    ("iwan5", ((1.000000, 0.999133, 0.865767), (0.354764, 1.000000, 0.777457), (0.048816, 0.122464, 1.000000))),
    ("iwan4_middle_stuck", ((1.000000, 0.988114, 0.914896), (0.355002, 1.000000, 0.776607),
                            (0.056319, 0.133064, 1.000000))))
    for i, surrogate in enumerate(TABLE5_BEAMS) for j, real in enumerate(TABLE5_BEAMS))
"""Paper Table 5, "Pairwise surrogacy confidence estimates" (section 5.2.2) with the BRB's damping factor: rows
(friction model, surrogate, real, SC), the model under its paper name (``FrictionModel.paper_name``: (a) Jenkins,
(b) 4-parameter Iwan, (c) 5-parameter Iwan, (d) middle-stuck 4-parameter Iwan), the matrices as printed (rows
surrogate, columns real, in ``TABLE5_BEAMS``' order)."""

TABLE6 = (("surrogate_beam", 2, 31.23, 15.616, 267.533, "<2e-16"),
          ("real_beam", 2, 56.80, 28.399, 486.523, "<2e-16"),
          ("friction_model", 3, 0.01, 0.005, 0.081, "0.971"),
          ("linearized_zeta", 2, 0.00, 0.000, 0.000, "1.000"),
          ("residuals", 1070, 62.46, 0.058, None, ""))
"""Paper Table 6, "ANOVA Table (4-way) for surrogacy confidence" (section 5.2.2): rows (factor, df, sum of
squares, mean square, F value, Pr(>F) as the paper prints it); the residuals have no F value."""

BRB_DECK = {"body_length": 0.29972, "lap_length": 0.12141, "width": 0.0254, "height": 0.0254,
            "bolt_x": (-0.030353, 0.0, 0.030353), "hole_diameter": 0.008433, "washer_outer_diameter": 0.0174625,
            "patch_cuts": (0.0, 0.125, 0.375, 0.625, 0.875, 1.0)}
"""The nominal BRB's dimensions in the ABAQUS deck (module docstring), m: each half a 0.29972 m (11.8 in) body of
full 25.4 x 25.4 mm section and a 0.12141 m lap of half the height; the three bolt axes relative to the lap centre
(pitch 1.195 in); the bolt holes (0.332 in) and the washers' outer diameter (11/16 in); the whole-joint patches cut
at these fractions of the lap length (patches 2-4 centred on the bolts, 1 and 5 bolt-free end strips). The deck's
material (192.85 GPa, 7857.8 kg/m^3) is ``fem.elasticity.DECK_MATERIAL``; the beams use the paper's 190 GPa and
nu = 0.29 (section 4.1) with 7800 kg/m^3 (``fem.elasticity.Material``)."""

TABLE_FILES = {"table1": "paper_table1_low_amplitude.csv", "table3": "paper_table3_parameter_limits.csv",
               "table5": "paper_table5_surrogacy.csv", "table6": "paper_table6_anova.csv"}
"""The file of each table in a ``--reference`` folder (CSV; columns in docs/formats.md)."""


class PaperTables(NamedTuple):
    """The paper's tables a stage uses, in the shapes of ``TABLE1``, ``TABLE3``, ``TABLE5`` and ``TABLE6``, and where
    each came from ("paper" for the values above, else the file read)."""

    table1: dict
    table3: dict
    table5: dict
    table6: tuple
    sources: dict


def paper_tables(reference: Path | None = None) -> PaperTables:
    """The paper's tables: the values of this module, each replaced by the user's file in ``reference`` where it
    holds one (``TABLE_FILES``). Raises ValueError naming the file, the row and the field of a bad value, or the
    folder where it is not one."""
    tables = {"table1": TABLE1, "table3": TABLE3, "table5": TABLE5, "table6": TABLE6}
    sources = dict.fromkeys(tables, "paper")
    if reference is not None:
        if not Path(reference).is_dir():
            raise ValueError(f"{reference}: no such folder (expected the paper's tables as "
                             f"{', '.join(TABLE_FILES.values())})")
        readers = {"table1": read_table1, "table3": read_table3, "table5": read_table5, "table6": read_table6}
        for name, file_name in TABLE_FILES.items():
            if (path := Path(reference) / file_name).is_file():
                tables[name], sources[name] = readers[name](path), str(path)
    return PaperTables(**tables, sources=sources)


def csv_rows(path: Path, columns: tuple[str, ...]) -> list[tuple[int, dict]]:
    """(line number, row) of a CSV file with a header naming at least ``columns``. Raises ValueError naming the
    file and the missing column."""
    with open(path, newline="") as stream:
        reader = csv.DictReader(stream)
        missing = [column for column in columns if column not in (reader.fieldnames or ())]
        if missing:
            raise ValueError(f"{path}: column '{missing[0]}' missing (expected the columns {', '.join(columns)})")
        return [(reader.line_num, row) for row in reader]


def number(path: Path, line: int, row: dict, field: str, expected: str) -> float:
    """The float in ``row[field]``. Raises ValueError naming the file, line and field where it is not one."""
    try:
        return float(row[field])
    except (TypeError, ValueError):
        raise ValueError(f"{path}: line {line}, field '{field}' = {row[field]!r}: expected {expected}") from None


def read_table1(path: Path) -> dict[str, LowAmplitude]:
    """A Table 1 file (columns beam, frequency_hz, damping_factor): beam -> LowAmplitude."""
    rows = csv_rows(path, ("beam", "frequency_hz", "damping_factor"))
    return {row["beam"]: LowAmplitude(row["beam"], number(path, line, row, "frequency_hz", "a frequency in Hz"),
                                      number(path, line, row, "damping_factor", "a damping factor (fraction)"))
            for line, row in rows}


def read_table3(path: Path) -> dict[str, tuple[float, float, bool]]:
    """A Table 3 file (columns parameter, minimum, maximum, sampling "log" or "linear"): parameter -> (minimum,
    maximum, logarithmic)."""
    limits = {}
    for line, row in csv_rows(path, ("parameter", "minimum", "maximum", "sampling")):
        if row["sampling"] not in ("log", "linear"):
            raise ValueError(f"{path}: line {line}, field 'sampling' = {row['sampling']!r}: expected log or linear")
        limits[row["parameter"]] = (number(path, line, row, "minimum", "a number"),
                                    number(path, line, row, "maximum", "a number"), row["sampling"] == "log")
    return limits


def read_table5(path: Path) -> tuple:
    """A Table 5 file (columns model, surrogate, real, confidence; the model under its paper name): rows as
    ``TABLE5``'s. Raises ValueError where a model lacks a pair of ``TABLE5_BEAMS``."""
    rows = tuple((row["model"], row["surrogate"], row["real"], number(path, line, row, "confidence", "a fraction"))
                 for line, row in csv_rows(path, ("model", "surrogate", "real", "confidence")))
    for model in dict.fromkeys(row[0] for row in rows):
        pairs = {(surrogate, real) for name, surrogate, real, _ in rows if name == model}
        missing = [(s, r) for s in TABLE5_BEAMS for r in TABLE5_BEAMS if (s, r) not in pairs]
        if missing:
            raise ValueError(f"{path}: model {model}: no row for surrogate {missing[0][0]}, real {missing[0][1]} "
                             f"(expected every pair of {', '.join(TABLE5_BEAMS)})")
    return rows


def read_table6(path: Path) -> tuple:
    """A Table 6 file (columns factor, df, sum_sq, mean_sq, f_value, p_value): rows as ``TABLE6``'s (an empty
    F value is None; the p-value kept as text, as the paper prints it)."""
    rows = []
    for line, row in csv_rows(path, ("factor", "df", "sum_sq", "mean_sq", "f_value", "p_value")):
        f_value = number(path, line, row, "f_value", "a number or nothing") if row["f_value"].strip() else None
        rows.append((row["factor"], int(number(path, line, row, "df", "a whole number")),
                     number(path, line, row, "sum_sq", "a number"), number(path, line, row, "mean_sq", "a number"),
                     f_value, row["p_value"]))
    return tuple(rows)
