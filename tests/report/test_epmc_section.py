"""The report's EPMC section (``report.epmc``): its table shows the differences of the comparison file, computed
here by hand from the file's numbers; the figure is drawn; an absent comparison is named with how to run it."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from report.document import Folders, write_pipeline_report
from report.epmc import epmc_section


def comparison_rows() -> pd.DataFrame:
    """BRB jenkins: one front design at four levels, the last not reached by EPMC; LBRB iwan4: two Table 3
    designs, harmonic counts 3 and 7, the second's check not converged."""
    rows = []
    jenkins = [(100.0, 100.0, 0.0, 0.0, True), (100.1, 100.0, 0.0104, 0.01, True), (99.0, 100.0, 0.02, 0.02, True),
               (98.0, float("nan"), 0.03, float("nan"), False)]
    for level, (fq, fe, zq, ze, converged) in enumerate(jenkins):
        rows.append({"dataset": "beams", "structure": "BRB", "model": "jenkins", "source": "front", "design": 12,
                     "parameters": json.dumps([1.0, 2.0, 3.0]), "amplitude": 1e-5 * (level + 1),
                     "slip_ratio": 0.1 * 10 ** level, "qsma_frequency_hz": fq, "qsma_damping": zq,
                     "qsma_converged": True, "epmc_frequency_hz": fe, "epmc_damping": ze, "epmc_converged": converged,
                     "harmonics": 5, "harmonics_converged": True})
    for design, (harmonics, converged) in enumerate([(3, True), (7, False)]):
        for level in range(2):
            rows.append({"dataset": "beams", "structure": "LBRB", "model": "iwan4", "source": "table3", "design": -1,
                         "parameters": json.dumps([float(design)]), "amplitude": 1e-5 * (level + 1),
                         "slip_ratio": 0.5, "qsma_frequency_hz": 80.0, "qsma_damping": 1.2e-3,
                         "qsma_converged": True, "epmc_frequency_hz": 80.0, "epmc_damping": 1e-3,
                         "epmc_converged": True, "harmonics": harmonics, "harmonics_converged": converged})
    return pd.DataFrame(rows)


def test_table_shows_the_differences_of_the_file(tmp_path):
    """BRB jenkins, by hand: frequency differences 0, 1e-3, 1e-2 on the three levels both reached (median 0.1 %,
    largest 1 %); damping differences 4e-2 and 0 where EPMC's zeta exceeds 1e-6 (the first level's is 0: not
    counted; median 2 %, largest 4 %); within 0.15 % and 5 %: the first two levels of three (67 %). LBRB iwan4:
    two designs, zeta 1.2e-3 against 1e-3 (20 %), harmonics 3 to 7, one check not converged."""
    (tmp_path / "epmc").mkdir()
    comparison_rows().to_csv(tmp_path / "epmc" / "study_beams.csv", index=False)
    lines = epmc_section(tmp_path, tmp_path, 10)
    assert lines[0] == "## 10. QSMA against the nonlinear mode by harmonic balance (EPMC)"
    assert "| BRB | jenkins (front) | 1 | 3 of 4 | 0.1 % | 1 % | 2 % | 4 % | 67 % | 5 | 0 |" in lines
    assert "| LBRB | iwan4 (table3) | 2 | 4 of 4 | 0 % | 0 % | 20 % | 20 % | 0 % | 3-7 | 1 |" in lines
    assert "![QSMA against EPMC](report_epmc.png)" in lines
    assert (tmp_path / "report_epmc.png").stat().st_size > 10_000


def test_an_absent_comparison_is_named_and_the_report_says_how_to_run_it(tmp_path):
    """No results/epmc: the section says the comparison was not run and names `make epmc`; the whole report
    carries it as its section 10 and draws no figure."""
    report = write_pipeline_report(Folders(tmp_path / "build", tmp_path / "results"), tmp_path / "report.md")
    text = report.read_text()
    assert "## 10. QSMA against the nonlinear mode by harmonic balance (EPMC)" in text
    assert "_EPMC comparison not run: `make epmc`" in text
    assert not (tmp_path / "report_epmc.png").exists()


def test_a_comparison_file_without_a_column_is_refused_naming_it(tmp_path):
    """A comparison file lacking a column the section reads: a ValueError naming the file and the column."""
    (tmp_path / "epmc").mkdir()
    comparison_rows().drop(columns="epmc_damping").to_csv(tmp_path / "epmc" / "study_asb.csv", index=False)
    with pytest.raises(ValueError, match=r"study_asb\.csv: not an EPMC comparison: column 'epmc_damping' missing"):
        epmc_section(tmp_path, tmp_path, 10)
