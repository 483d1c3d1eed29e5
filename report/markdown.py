"""The report's Markdown lines that every section writes alike: links relative to the report, figures (a figure
absent is named, never linked), stages that did not run, and the virtual experiments' lowest-amplitude
frequencies against paper Table 1."""

from __future__ import annotations

import csv
import os
from pathlib import Path

FETCH = "`make data` (`surrogacy data fetch`)"
"""The command that fetches the public measured data (``pipeline.public_data``)."""


def relative_link(target: Path, start: Path) -> str:
    """``target`` relative to the folder ``start``, with forward slashes (Markdown links)."""
    return Path(os.path.relpath(Path(target).resolve(), Path(start).resolve())).as_posix()


def image_line(target: Path, caption: str, report_folder: Path, ran: bool = True) -> str:
    """A Markdown image line for the figure ``target``, linked relative to ``report_folder``; where the file is
    absent, a line saying so instead: not written where its stage did not run (``ran`` false), missing where it
    did (deleted, or not drawn). Never a broken link."""
    if Path(target).exists():
        return f"![{caption}]({relative_link(target, report_folder)})"
    if not ran:
        return f"_{caption}: {target} not written (stage not run)_"
    return (f"_{caption}: figure missing: {target} is absent although its stage ran (deleted, or not drawn: rerun "
            "the stage to draw it)_")


def measured_stage_not_run(stage: str, data: str) -> str:
    """The report's line for a stage that reads measured data and did not run: the data it reads and the command
    that fetches it (a demo without the data skips the stage)."""
    return f"_{stage} not run: it reads {data}; {FETCH} fetches the data where it is absent_"


def low_amplitude_markdown(path: Path) -> list[str]:
    """The virtual experiments' lowest-amplitude frequency of each beam against paper Table 1 (Hz, and their
    difference in %), from their ``low_amplitude.csv`` (``virtual_experiment.hammer_test``), as Markdown rows
    under their header."""
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    return ["| beam | virtual (Hz) | Table 1 (Hz) | difference (%) |", "|---|---|---|---|",
            *(f"| {row['beam']} | {float(row['virtual_hz']):.2f} | {float(row['table1_hz']):.2f} | "
              f"{float(row['difference_percent']):+.2f} |" for row in rows)]
