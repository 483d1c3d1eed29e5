"""``surrogacy report``: the pipeline's report (``report.document``), one Markdown file with every stage's
figures and tables, from the files the stages wrote into ``--build`` and ``--results``. Per-stage timings come from
the run log given to ``surrogacy --run-log FILE`` (``make demo`` keeps one in results/runs.jsonl)."""

from __future__ import annotations

import argparse
from pathlib import Path

from report.document import Folders, write_pipeline_report


def run(arguments: argparse.Namespace) -> None:
    """Write the report and print its path."""
    for folder, option in ((arguments.build, "--build"), (arguments.results, "--results")):
        if not folder.is_dir():
            raise ValueError(f"{option} {folder}: not a folder (run the stages first, e.g. make demo)")
    path = write_pipeline_report(Folders(arguments.build, arguments.results, arguments.run_log), arguments.out)
    print(f"report: {path}")


def register(subparsers) -> None:
    """Add the ``report`` subcommand."""
    command = subparsers.add_parser("report", help="the pipeline's report: every stage's figures and tables",
                                    description=__doc__)
    command.add_argument("--build", type=Path, default=Path("build"), help="folder with beams/, fe/, rom/")
    command.add_argument("--results", type=Path, default=Path("results"),
                         help="folder with freevib/, study-beams/, study-asb/, discrepancy/")
    command.add_argument("--out", type=Path, default=Path("results/report.md"), help="the report (Markdown)")
    command.set_defaults(run=run)
