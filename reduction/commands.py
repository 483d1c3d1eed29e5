"""``surrogacy rom``: the reduction stage. Parses its options, checks every beam's inputs before the output folder
is touched, and writes each beam's superelement (:mod:`reduction.rom_files`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from fem.fe_files import FeInputError, beam_inputs
from geometry.parameters import BEAMS
from pipeline.config import add_config_arguments, configuration
from pipeline.files import check_output_folder, stage_folder

from . import rom_files
from .craig_bampton import N_FIXED_INTERFACE_MODES


def run(arguments: argparse.Namespace) -> None:
    if arguments.modes is not None and arguments.modes < 1:
        raise FeInputError(f"option --modes = {arguments.modes}: expected at least 1 fixed-interface mode")
    options = [("reduction", "fixed_interface_modes", arguments.modes)] if arguments.modes is not None else []
    parameters = configuration(arguments, {"reduction": rom_files.ReductionParameters()}, options)["reduction"]
    check_output_folder(arguments.out)
    for name in arguments.beam:  # every beam's inputs checked before the output folder is touched
        rom_files.fe_inputs(arguments.fe, name, beam_inputs(arguments.beams, name)[2])
    with stage_folder(arguments.out):
        for name in tqdm(arguments.beam, desc="superelements", unit="beam"):
            tqdm.write(f"{name}: {rom_files.make_rom(name, arguments.beams, arguments.fe, arguments.out, parameters)}")



def register(subparsers) -> None:
    """Add the ``rom`` subcommand."""
    command = subparsers.add_parser(
        "rom", help="whole-joint patches and Hurty/Craig-Bampton superelement of each beam: build/rom/<beam>.npz",
        description=rom_files.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--beam", nargs="+", choices=sorted(BEAMS), default=list(BEAMS), help="beams to reduce")
    command.add_argument("--beams", type=Path, default=Path("build/beams"), help="geometry stage output folder")
    command.add_argument("--fe", type=Path, default=Path("build/fe"), help="FE stage output folder")
    command.add_argument("--out", type=Path, default=Path("build/rom"), help="output folder")
    command.add_argument("--modes", type=int, help=f"fixed-interface modes (reduction.fixed_interface_modes, "
                                                   f"default {N_FIXED_INTERFACE_MODES})")
    add_config_arguments(command, "a [reduction]", "reduction.sensor_body_fractions=[0.2, 0.4, 0.6, 0.8]")
    command.set_defaults(run=run)

