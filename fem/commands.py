"""``surrogacy fe``, ``fe-convergence`` and ``tune-frequencies``: the finite-element stage and its two studies. Each
parses its options, calls the library (:mod:`fem.fe_files`, :mod:`fem.convergence`, :mod:`fem.frequency_tuning`)
and prints what it wrote."""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from geometry.parameters import BEAMS, MeshParameters
from pipeline.config import add_config_arguments, configuration
from pipeline.files import stage_folder

from . import convergence, fe_files, frequency_tuning
from .bolts import Bolt
from .elasticity import Material


MATERIAL_OPTIONS = ("youngs_modulus", "poissons_ratio", "density")  # --youngs-modulus ...: material.<field>


def run_fe(arguments: argparse.Namespace) -> None:
    options = [("material", field, getattr(arguments, field)) for field in MATERIAL_OPTIONS
               if getattr(arguments, field) is not None]
    resolved = configuration(arguments, {"material": Material(), "bolt": Bolt()}, options)
    fe_files.check_fe_inputs(arguments.beam, arguments.beams, arguments.out, arguments.modes)
    with stage_folder(arguments.out):
        for name in tqdm(arguments.beam, desc="FE models", unit="beam"):
            sidecar = fe_files.make_fe(name, arguments.beams, arguments.out, resolved["material"], resolved["bolt"],
                                       arguments.modes)
            tqdm.write(f"{name}: {sidecar}")


def register(subparsers) -> None:
    """Add the ``fe`` subcommand and the FE studies (``fe-convergence``, ``tune-frequencies``)."""
    command = subparsers.add_parser(
        "fe", help="preload with contact, stress stiffness and tied modes of each beam: build/fe/<beam>.npz",
        description=fe_files.__doc__)
    command.add_argument("--beam", nargs="+", choices=sorted(BEAMS), default=list(BEAMS), help="beams to solve")
    command.add_argument("--beams", type=Path, default=Path("build/beams"), help="geometry stage output folder")
    command.add_argument("--out", type=Path, default=Path("build/fe"), help="output folder")
    command.add_argument("--modes", type=int, default=fe_files.N_MODES, help="tied modes per solve, six rigid included")
    command.add_argument("--youngs-modulus", type=float, help=f"Pa (material.youngs_modulus, default "
                                                                f"{Material().youngs_modulus:g})")
    command.add_argument("--poissons-ratio", type=float,
                         help=f"material.poissons_ratio, default {Material().poissons_ratio:g}")
    command.add_argument("--density", type=float, help=f"kg/m^3 (material.density, default {Material().density:g})")
    add_config_arguments(command, "[material] and [bolt]", "material.density=7850 or bolt.preload=12000")
    command.set_defaults(run=run_fe)
    register_convergence(subparsers)
    register_tuning(subparsers)


def run_convergence(arguments: argparse.Namespace) -> None:
    sizes = MeshParameters(arguments.size, arguments.lap_size, arguments.hole_size)
    material = Material(arguments.youngs_modulus, arguments.poissons_ratio, arguments.density)
    table, record = convergence.write_study(BEAMS[arguments.beam], sizes, arguments.factors, arguments.out, material,
                                            arguments.tolerance, progress=True)
    tqdm.write(f"{table}: coarsest mesh within {arguments.tolerance:g} of every finer one: "
               f"s = {record['converged_factor']}, {record['converged_dof']} DOF")


def register_convergence(subparsers) -> None:
    """Add the ``fe-convergence`` subcommand."""
    sizes, material = MeshParameters(), Material()
    command = subparsers.add_parser(
        "fe-convergence", help="mesh-convergence study of the tied first bending: results/fe-convergence/<beam>.csv",
        description=convergence.__doc__)
    command.add_argument("--beam", choices=sorted(BEAMS), default="BRB")
    command.add_argument("--factors", type=float, nargs="+", default=list(convergence.FACTORS),
                         help="scale factors on the three element sizes (< 1 refines)")
    command.add_argument("--size", type=float, default=sizes.size, help="base far-field element size, m")
    command.add_argument("--lap-size", type=float, default=sizes.lap_size, help="base lap element size, m")
    command.add_argument("--hole-size", type=float, default=sizes.hole_size, help="base hole element size, m")
    command.add_argument("--tolerance", type=float, default=convergence.TOLERANCE, help="relative change to the next finer mesh")
    command.add_argument("--youngs-modulus", type=float, default=material.youngs_modulus, help="Pa")
    command.add_argument("--poissons-ratio", type=float, default=material.poissons_ratio)
    command.add_argument("--density", type=float, default=material.density, help="kg/m^3")
    command.add_argument("--out", type=Path, default=Path("results/fe-convergence"), help="output folder")
    command.set_defaults(run=run_convergence)


def run_tuning(arguments: argparse.Namespace) -> None:
    path, record = frequency_tuning.write_tuning(arguments.out, arguments.mesh_factor, arguments.stiffness,
                                                 progress=True)
    tqdm.write(f"{path}: LBRB.body_length = {record['LBRB']['body_length']:.6g} m, "
               f"SBRB.spring_height = {record['SBRB']['spring_height']:.6g} m")


def register_tuning(subparsers) -> None:
    """Add the ``tune-frequencies`` subcommand."""
    command = subparsers.add_parser(
        "tune-frequencies", help="joint springs of the BRB and LBRB/SBRB geometry tuned to the measured first-bending "
                                 "frequencies (Table 1)",
        description=frequency_tuning.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--mesh-factor", type=float, default=frequency_tuning.MESH_FACTOR,
                         help="scale factor on the default element sizes (geometry.parameters.MeshParameters)")
    command.add_argument("--stiffness", type=float, default=None,
                         help="BRB patch stiffness k, N/m, found before on the same mesh: skip step 1")
    command.add_argument("--out", type=Path, default=Path("results/frequency-tuning"), help="output folder")
    command.set_defaults(run=run_tuning)

