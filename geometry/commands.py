"""``surrogacy beams``: mesh the Brake-Reuss beams (the geometry stage).

Parameters: a ``[mesh]`` table (``geometry.parameters.MeshParameters``) and one table per beam, ``[BRB]``,
``[LBRB]``, ``[SBRB]`` (``BeamParameters``), in a ``--config`` TOML file and ``--set`` overrides
(``pipeline.config``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from pipeline.config import add_config_arguments, configuration
from pipeline.files import stage_folder

from .beams import make_beam
from .parameters import BEAMS, MeshParameters, check_mesh_size


def run(arguments: argparse.Namespace) -> None:
    resolved = configuration(arguments, {"mesh": MeshParameters(), **BEAMS})
    for name in arguments.beam:  # every beam's mesh size checked before anything is written
        check_mesh_size(resolved[name], resolved["mesh"])
    with stage_folder(arguments.out):
        for name in tqdm(arguments.beam, desc="meshing beams", unit="beam"):
            sidecar = make_beam(resolved[name], resolved["mesh"], arguments.out, render=not arguments.no_render)
            tqdm.write(f"{name}: {sidecar}")


def register(subparsers) -> None:
    """Add the ``beams`` subcommand."""
    command = subparsers.add_parser(
        "beams", help="mesh the BRB, LBRB and SBRB (gmsh): .msh, .vtu, .png and a .json sidecar per beam",
        description=__doc__)
    command.add_argument("--beam", nargs="+", choices=sorted(BEAMS), default=list(BEAMS), help="beams to mesh")
    command.add_argument("--out", type=Path, default=Path("build/beams"), help="output folder")
    add_config_arguments(command, "[mesh] and per-beam [BRB]/[LBRB]/[SBRB]",
                         "mesh.size=0.005 or SBRB.spring_height=0.007")
    command.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    command.set_defaults(run=run)
