"""The one benchmark table: a row per measurement, printed as it is measured and written to results/bench.

A row is a dict with the keys of ``COLUMNS``: stage (geometry, fem, reduction, qsma, study, dask, bench); case
(beam and step, friction model, scheduler); seconds (wall or CPU time as the note says, s) or None; peak_mib
(peak resident memory, MiB) or None; rate (a throughput or a ratio) or None with its unit (``designs/s/core``,
``x serial``, ...); note (what was measured, the result that shows the step did its work). The table is Markdown
with fixed column widths, so that each line can be printed the moment its row is measured.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable
from pathlib import Path

from pipeline.files import atomic_path

COLUMNS = ("stage", "case", "seconds", "peak_mib", "rate", "unit", "note")
HEADINGS = ("stage", "case", "time (s)", "peak memory (MiB)", "rate", "note")
WIDTHS = (9, 34, 8, 17, 25)  # every column but the note


def row(stage: str, case: str, seconds: float | None = None, peak_mib: float | None = None,
        rate: float | None = None, unit: str = "", note: str = "") -> dict:
    """One measurement: seconds in s, peak_mib in MiB, rate in ``unit``; None where not measured."""
    return {"stage": stage, "case": case, "seconds": seconds, "peak_mib": peak_mib, "rate": rate, "unit": unit,
            "note": note}


def _number(value: float | None, digits: int) -> str:
    """A measured value for the table: thousands separated above 100, ``digits`` decimals below, '-' if None."""
    if value is None:
        return "-"
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.{digits}f}"


def _line(cells: Iterable[str]) -> str:
    cells = list(cells)
    return "| " + " | ".join(cell.ljust(width) for cell, width in zip(cells, WIDTHS)) + f" | {cells[-1]} |"


def header() -> list[str]:
    """The table's heading line and its Markdown rule."""
    return [_line(HEADINGS), _line("-" * width for width in (*WIDTHS, 4))]


def markdown_line(measurement: dict) -> str:
    """One row as a Markdown table line."""
    rate = _number(measurement["rate"], 2)
    return _line([measurement["stage"], measurement["case"], _number(measurement["seconds"], 2),
                  _number(measurement["peak_mib"], 0),
                  f"{rate} {measurement['unit']}" if measurement["rate"] is not None else "-", measurement["note"]])


def show(rows: Iterable[dict], preamble: Iterable[str] = ()) -> list[dict]:
    """Print the preamble, the heading, then each row the moment it is measured; returns the rows."""
    for line in (*preamble, *header()):
        print(line, flush=True)
    measured = []
    for measurement in rows:
        print(markdown_line(measurement), flush=True)
        measured.append(measurement)
    return measured


def write(rows: list[dict], folder: Path, preamble: Iterable[str] = ()) -> tuple[Path, Path]:
    """Write the table as ``<folder>/bench.md`` (preamble and Markdown table) and ``bench.csv`` (``COLUMNS``,
    numbers unformatted), each renamed into place whole; returns both paths."""
    markdown, table = Path(folder) / "bench.md", Path(folder) / "bench.csv"
    with atomic_path(markdown) as temporary:
        temporary.write_text("\n".join([*preamble, "", *header(), *map(markdown_line, rows)]) + "\n")
    with atomic_path(table) as temporary, open(temporary, "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return markdown, table
