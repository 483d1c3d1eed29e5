"""The benchmark table (``benchmarks.table``): one Markdown line per row, columns aligned, CSV beside it; and the
measurement of a step (``benchmarks.peak``) that dies without reporting."""

import csv
import os
import signal

import pytest

from benchmarks.peak import measure
from benchmarks.table import header, markdown_line, row, write


def bars(line: str) -> list[int]:
    """Positions of the column separators before the note."""
    return [i for i, character in enumerate(line) if character == "|"][:6]


def test_rows_line_up_under_the_heading_and_keep_their_values(tmp_path):
    rows = [row("qsma", "iwan4, 1 core", 0.2567, 321.4, 15591.2, "designs/s/core", "best of 5"),
            row("fem", "BRB CalculiX / ours: tied modes", rate=3.456, unit="x", note="> 1: ours faster"),
            row("study", "all models", note="skipped")]
    lines = [*header(), *map(markdown_line, rows)]
    assert all(bars(line) == bars(lines[0]) for line in lines)
    assert [cell.strip() for cell in lines[2].split("|")[1:-1]] == [
        "qsma", "iwan4, 1 core", "0.26", "321", "15,591 designs/s/core", "best of 5"]
    assert "3.46 x" in lines[3]
    assert [cell.strip() for cell in lines[4].split("|")[3:6]] == ["-", "-", "-"]  # nothing measured
    markdown, table = write(rows, tmp_path, ["preamble"])
    assert markdown.read_text() == "\n".join(["preamble", "", *lines]) + "\n"
    with open(table) as stream:
        read = list(csv.DictReader(stream))
    assert float(read[0]["rate"]) == 15591.2 and read[2]["seconds"] == "" and read[1]["note"] == "> 1: ours faster"


def killed_outright():
    """A benchmark step that dies as an out-of-memory kill would: SIGKILL, nothing reported."""
    os.kill(os.getpid(), signal.SIGKILL)


def test_measure_reports_a_step_killed_outright():
    """The parent used to wait forever for the result of a child killed outright."""
    with pytest.raises(RuntimeError, match="exit code -9"):
        measure(killed_outright)
