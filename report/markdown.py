"""The report's Markdown lines that several sections write alike: stages that did not run, named with the public
measured data they read. Figures and links relative to the report are ``study.report``'s (``image_line``,
``relative_link``), which the study's own report writes alike."""

from __future__ import annotations

FETCH = "`make data` (`surrogacy data fetch`)"
"""The command that fetches the public measured data (``pipeline.public_data``)."""


def measured_stage_not_run(stage: str, data: str) -> str:
    """The report's line for a stage that reads measured data and did not run: the data it reads and the command
    that fetches it (a demo without the data skips the stage)."""
    return f"_{stage} not run: it reads {data}; {FETCH} fetches the data where it is absent_"
