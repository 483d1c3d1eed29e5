"""``surrogacy data fetch``: the public measured data (:mod:`pipeline.public_data`); ``make data`` calls it."""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline import public_data


def fetch(arguments: argparse.Namespace) -> None:
    """Download the public measured files into ``arguments.out``, hashes checked."""
    paths = public_data.fetch(arguments.out, arguments.base_url, retries=arguments.retries,
                              progress=not arguments.quiet)
    print(f"{len(paths)} files in {arguments.out}: ASB data --data {arguments.out}, ring-down --ringdown "
          f"{arguments.out / 'chen2022-brb-hammer' / 'HammerImpact.mat'}")


def register(subparsers) -> None:
    """Add the ``data`` subcommand (``data fetch``)."""
    command = subparsers.add_parser("data", help="the public measured data: fetch it, hashes checked",
                                    description=public_data.__doc__,
                                    formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = command.add_subparsers(dest="action", required=True, metavar="ACTION")
    action = actions.add_parser("fetch", help="download every public file (ASB backbones and reduced models, the "
                                              "Chen 2022 ring-down) into a folder, each SHA-256 checked")
    action.add_argument("--out", type=Path, default=Path("data"), help="the data folder (default data/)")
    action.add_argument("--base-url", help="a mirror holding the files under their names here (default "
                                           f"${public_data.BASE_URL_VARIABLE}, else the public sources)")
    action.add_argument("--retries", type=int, default=2, help="further attempts of a failed download")
    action.add_argument("--quiet", action="store_true", help="no progress bars")
    action.set_defaults(run=fetch)
